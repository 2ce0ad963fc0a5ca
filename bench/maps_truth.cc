#include "bench/maps_truth.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/float_tiff.h"
#include "common/io.h"
#include "common/math.h"

namespace fs = std::filesystem;

namespace gonio::bench {
namespace {

// A truth map on its grid: bilinear (or nearest) lookup at a board point.
struct TruthMap {
  cv::Mat image;
  double texel = 0, x0 = 0, y0 = 0;  // centre of texel (0, 0)
  // Channel c at board (x, y); nearest texel when `nearest`.
  double At(double x, double y, int c, bool nearest = false) const {
    const double u = (x - x0) / texel, v = (y - y0) / texel;
    const int C = image.channels();
    if (nearest) {
      const int i = std::clamp(static_cast<int>(std::lround(u)), 0, image.cols - 1);
      const int j = std::clamp(static_cast<int>(std::lround(v)), 0, image.rows - 1);
      return image.ptr<float>(j)[i * C + c];
    }
    const int i = std::clamp(static_cast<int>(std::floor(u)), 0, image.cols - 2);
    const int j = std::clamp(static_cast<int>(std::floor(v)), 0, image.rows - 2);
    const double fx = std::clamp(u - i, 0.0, 1.0), fy = std::clamp(v - j, 0.0, 1.0);
    const float* a = image.ptr<float>(j);
    const float* b = image.ptr<float>(j + 1);
    return (1 - fy) * ((1 - fx) * a[i * C + c] + fx * a[(i + 1) * C + c]) +
           fy * ((1 - fx) * b[i * C + c] + fx * b[(i + 1) * C + c]);
  }
};

double Rms(double sum_sq, size_t n) { return n ? std::sqrt(sum_sq / n) : 0.0; }

cv::Mat ReadMap(const fs::path& path) { return ReadFloatTiff(path); }

// The truth's albedo, normal, roughness and material maps on the truth's texel grid.
struct TruthMaps {
  TruthMap albedo, normal, rough, materials;
};

TruthMaps ReadTruthMaps(const nlohmann::json& truth, const fs::path& truth_dir) {
  const auto& tg = truth["texture"]["grid"];
  auto truth_map = [&](const std::string& key) {
    TruthMap m;
    m.image = ReadMap(truth_dir / truth["texture"]["files"][key].get<std::string>());
    m.texel = tg["texel_m"].get<double>();
    m.x0 = tg["first_texel_centre_in_board"][0].get<double>();
    m.y0 = tg["first_texel_centre_in_board"][1].get<double>();
    return m;
  };
  TruthMaps t;
  t.albedo = truth_map("albedo");
  t.normal = truth_map("normal");
  t.rough = truth_map("roughness");
  t.materials = truth_map("materials");
  return t;
}

// The maps of a `gonio maps` output folder with their standard deviations and mask.
struct FittedMaps {
  cv::Mat albedo, sd_albedo, normal, sd_normal, materials, rough, sd_rough, mask;
  bool has_rough = false;
};

FittedMaps ReadFittedMaps(const nlohmann::json& maps, const fs::path& maps_dir) {
  FittedMaps f;
  const std::string channel_param = maps["channel_parameters"].get<std::string>();
  const std::string albedo_file = channel_param.rfind("diffuse", 0) == 0 ? "diffuse" : "albedo";
  f.albedo = ReadMap(maps_dir / (albedo_file + ".tiff"));
  f.sd_albedo = ReadMap(maps_dir / ("sd_" + albedo_file + ".tiff"));
  f.normal = ReadMap(maps_dir / "normal.tiff");
  f.sd_normal = ReadMap(maps_dir / "sd_normal.tiff");
  f.materials = ReadMap(maps_dir / "materials.tiff");
  f.has_rough = fs::exists(maps_dir / "roughness.tiff");
  if (f.has_rough) {
    f.rough = ReadMap(maps_dir / "roughness.tiff");
    f.sd_rough = ReadMap(maps_dir / "sd_roughness.tiff");
  }
  f.mask = cv::imread((maps_dir / "mask.png").string(), cv::IMREAD_GRAYSCALE);
  if (f.mask.empty()) throw InputError((maps_dir / "mask.png").string() + ": cannot be read");
  return f;
}

// A masked texel of the fitted maps: its board point and whether the truth's material is the
// same within the edge band around it.
struct Texel {
  double x, y;
  int i, j;
  bool interior;
};

// The masked texels; the fitted grid's texel (0, 0) is centred at (x0, y0) + (dx, dy).
std::vector<Texel> MaskedTexels(const FittedMaps& f, const TruthMap& t_mat, double texel, double x0,
                                double y0, double dx, double dy, double band) {
  std::vector<Texel> texels;
  for (int j = 0; j < f.albedo.rows; ++j) {
    for (int i = 0; i < f.albedo.cols; ++i) {
      if (!f.mask.at<uint8_t>(j, i)) continue;
      const double x = x0 + i * texel + dx, y = y0 + j * texel + dy;
      const double m0 = t_mat.At(x, y, 0, true);
      bool interior = true;
      for (int k = 0; k < 8 && interior; ++k) {
        const double a = k * kPi / 4;
        interior = t_mat.At(x + band * std::cos(a), y + band * std::sin(a), 0, true) == m0;
      }
      texels.push_back({x, y, i, j, interior});
    }
  }
  return texels;
}

// The sums of squared errors (and z-scores) over the texels, interior and all.
struct ErrorSums {
  double a2 = 0, a2_all = 0, az2 = 0, n2 = 0, n2_all = 0, nz2 = 0, r2 = 0, rz2 = 0;
  size_t na = 0, na_all = 0;
  std::map<std::pair<int, int>, size_t> confusion;  // (true material, cluster) -> texels
};

void AddTexelErrors(const Texel& t, const FittedMaps& f, const TruthMaps& truth,
                    MapsTruthComparison* r, ErrorSums* s) {
  const int C = f.albedo.channels();
  ++r->texels;
  const float* a = f.albedo.ptr<float>(t.j) + t.i * C;
  const float* sa = f.sd_albedo.ptr<float>(t.j) + t.i * C;
  double ae2 = 0, az = 0;
  for (int c = 0; c < C; ++c) {
    const double truth_a = r->albedo_scale[c] * truth.albedo.At(t.x, t.y, C == 3 ? c : 1);
    const double e = a[c] - truth_a;
    ae2 += (e / truth_a) * (e / truth_a);
    az += sa[c] > 0 ? (e / sa[c]) * (e / sa[c]) : 0.0;
  }
  const float* nm = f.normal.ptr<float>(t.j) + t.i * 3;
  const Eigen::Vector3d nf(nm[0], nm[1], nm[2]);
  const Eigen::Vector3d nt =
      Eigen::Vector3d(truth.normal.At(t.x, t.y, 0), truth.normal.At(t.x, t.y, 1),
                      truth.normal.At(t.x, t.y, 2))
          .normalized();
  const double angle = RadToDeg(std::atan2(nf.cross(nt).norm(), nf.dot(nt)));
  s->a2_all += ae2;
  s->na_all += C;
  s->n2_all += angle * angle;
  if (!t.interior) return;
  ++r->interior;
  s->a2 += ae2;
  s->na += C;
  s->az2 += az;
  s->n2 += angle * angle;
  const double sn = f.sd_normal.at<float>(t.j, t.i);
  if (sn > 0) s->nz2 += (angle / sn) * (angle / sn);
  if (f.has_rough) {
    const double e = f.rough.at<float>(t.j, t.i) - truth.rough.At(t.x, t.y, 0);
    s->r2 += e * e;
    const double sr = f.sd_rough.at<float>(t.j, t.i);
    if (sr > 0) s->rz2 += (e / sr) * (e / sr);
  }
  ++s->confusion[{static_cast<int>(std::lround(truth.materials.At(t.x, t.y, 0, true))),
                  static_cast<int>(std::lround(f.materials.at<float>(t.j, t.i)))}];
}

// Each found cluster counted for the truth material most of its texels have, over the interior
// texels.
double MaterialAgreement(const std::map<std::pair<int, int>, size_t>& confusion, size_t interior) {
  std::map<int, std::pair<int, size_t>> best;  // cluster -> (material, count)
  for (const auto& [key, count] : confusion) {
    auto& b = best[key.second];
    if (count > b.second) b = {key.first, count};
  }
  size_t agree = 0;
  for (const auto& [cluster, b] : best) agree += b.second;
  return interior ? static_cast<double>(agree) / interior : 0.0;
}

}  // namespace

nlohmann::json MapsTruthComparison::ToJson() const {
  return {{"texels", texels},
          {"interior_texels", interior},
          {"albedo_rel_rms", albedo_rel_rms},
          {"albedo_rel_rms_all", albedo_rel_rms_all},
          {"albedo_rms_z", albedo_rms_z},
          {"albedo_scale", {albedo_scale[0], albedo_scale[1], albedo_scale[2]}},
          {"normal_rms_deg", normal_rms_deg},
          {"normal_rms_deg_all", normal_rms_deg_all},
          {"normal_rms_z", normal_rms_z},
          {"roughness_rms", roughness_rms},
          {"roughness_rms_deg", roughness_rms_deg},
          {"roughness_rms_z", roughness_rms_z},
          {"materials_found", materials_found},
          {"materials_true", materials_true},
          {"material_agreement", material_agreement}};
}

std::string MapsTruthComparison::Report() const {
  return fmt::format(
      "against truth ({} interior of {} texels): albedo {:.3f}% RMS (z {:.2f}; all texels "
      "{:.3f}%), normal {:.3f} deg RMS (z {:.2f}; all {:.3f}), roughness {:.4f} ({:.3f} deg, z "
      "{:.2f}), materials {} of {} (agreement {:.3f})",
      interior, texels, 100 * albedo_rel_rms, albedo_rms_z, 100 * albedo_rel_rms_all,
      normal_rms_deg, normal_rms_z, normal_rms_deg_all, roughness_rms, roughness_rms_deg,
      roughness_rms_z, materials_found, materials_true, material_agreement);
}

MapsTruthComparison CompareMapsWithTruth(const fs::path& maps_dir, const fs::path& truth_dir,
                                         const MapsTruthOptions& o) {
  const nlohmann::json maps = ReadJsonFile(maps_dir / "maps.json");
  const nlohmann::json truth = ReadJsonFile(truth_dir / "truth.json");
  if (!truth.contains("texture")) throw InputError(truth_dir.string() + ": truth has no texture");
  const TruthMaps t = ReadTruthMaps(truth, truth_dir);
  const auto& g = maps["grid"];
  const double texel = g["texel_m"].get<double>();
  const double x0 = g["first_texel_centre_in_board"][0].get<double>();
  const double y0 = g["first_texel_centre_in_board"][1].get<double>();
  // A rectified capture's frame is centred on its square: its truth says where that is.
  double dx = 0, dy = 0;
  if (truth.contains("rectified") && maps["lamp"]["frame"] == "per-view") {
    dx = truth["rectified"]["centre_in_board"][0].get<double>();
    dy = truth["rectified"]["centre_in_board"][1].get<double>();
  }
  const FittedMaps f = ReadFittedMaps(maps, maps_dir);
  const int C = f.albedo.channels();
  MapsTruthComparison r;
  r.materials_found = maps["clusters"]["k"].get<int>();
  r.materials_true = static_cast<int>(truth["texture"]["materials"].size());
  const std::vector<Texel> texels =
      MaskedTexels(f, t.materials, texel, x0, y0, dx, dy, o.edge_band_m);
  // Albedo scale per channel (least squares of fitted on true) when asked.
  for (int c = 0; c < C && o.fit_albedo_scale; ++c) {
    double num = 0, den = 0;
    for (const auto& tx : texels) {
      const double a = t.albedo.At(tx.x, tx.y, c);
      num += a * f.albedo.ptr<float>(tx.j)[tx.i * C + c];
      den += a * a;
    }
    r.albedo_scale[c] = den > 0 ? num / den : 1.0;
  }
  ErrorSums s;
  for (const auto& tx : texels) AddTexelErrors(tx, f, t, &r, &s);
  r.albedo_rel_rms = Rms(s.a2, s.na);
  r.albedo_rel_rms_all = Rms(s.a2_all, s.na_all);
  r.albedo_rms_z = Rms(s.az2, s.na);
  r.normal_rms_deg = Rms(s.n2, r.interior);
  r.normal_rms_deg_all = Rms(s.n2_all, r.texels);
  r.normal_rms_z = Rms(s.nz2, r.interior);
  r.roughness_rms = Rms(s.r2, r.interior);
  r.roughness_rms_deg = RadToDeg(r.roughness_rms);
  r.roughness_rms_z = Rms(s.rz2, r.interior);
  r.material_agreement = MaterialAgreement(s.confusion, r.interior);
  return r;
}

}  // namespace gonio::bench
