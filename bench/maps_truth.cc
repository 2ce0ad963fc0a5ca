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

}  // namespace

nlohmann::json MapsTruthComparison::ToJson() const {
  return {{"texels", texels},
          {"interior_texels", interior},
          {"edge_texels", edge},
          {"edge_albedo_rel_rms", edge_albedo_rel_rms},
          {"edge_albedo_rms_z", edge_albedo_rms_z},
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
      "{:.2f}), materials {} of {} (agreement {:.3f}); {} edge texels: albedo {:.3f}% RMS (z "
      "{:.2f})",
      interior, texels, 100 * albedo_rel_rms, albedo_rms_z, 100 * albedo_rel_rms_all,
      normal_rms_deg, normal_rms_z, normal_rms_deg_all, roughness_rms, roughness_rms_deg,
      roughness_rms_z, materials_found, materials_true, material_agreement, edge,
      100 * edge_albedo_rel_rms, edge_albedo_rms_z);
}

namespace {

// The truth's maps (truth.json "texture"), on the truth's grid.
struct Truth {
  TruthMap albedo, normal, rough, mat;
  int materials = 0;
};

Truth ReadTruth(const fs::path& truth_dir, const nlohmann::json& truth) {
  if (!truth.contains("texture")) throw InputError(truth_dir.string() + ": truth has no texture");
  const auto& tg = truth["texture"]["grid"];
  auto truth_map = [&](const std::string& key) {
    TruthMap m;
    m.image = ReadMap(truth_dir / truth["texture"]["files"][key].get<std::string>());
    m.texel = tg["texel_m"].get<double>();
    m.x0 = tg["first_texel_centre_in_board"][0].get<double>();
    m.y0 = tg["first_texel_centre_in_board"][1].get<double>();
    return m;
  };
  Truth t;
  t.albedo = truth_map("albedo");
  t.normal = truth_map("normal");
  t.rough = truth_map("roughness");
  t.mat = truth_map("materials");
  t.materials = static_cast<int>(truth["texture"]["materials"].size());
  return t;
}

// The maps' files and where their texels are on the board.
struct Maps {
  cv::Mat albedo, sd_albedo, normal, sd_normal, materials, rough, sd_rough, mask, edges;
  bool has_rough = false;
  double texel = 0, x0 = 0, y0 = 0, dx = 0, dy = 0;
  int materials_found = 0;
};

Maps ReadMaps(const fs::path& maps_dir, const nlohmann::json& maps, const nlohmann::json& truth) {
  Maps m;
  const auto& g = maps["grid"];
  m.texel = g["texel_m"].get<double>();
  m.x0 = g["first_texel_centre_in_board"][0].get<double>();
  m.y0 = g["first_texel_centre_in_board"][1].get<double>();
  // A rectified capture's frame is centred on its square: its truth says where that is.
  if (truth.contains("rectified") && maps["lamp"]["frame"] == "per-view") {
    m.dx = truth["rectified"]["centre_in_board"][0].get<double>();
    m.dy = truth["rectified"]["centre_in_board"][1].get<double>();
  }
  const std::string channel_param = maps["channel_parameters"].get<std::string>();
  const std::string albedo_file = channel_param.rfind("diffuse", 0) == 0 ? "diffuse" : "albedo";
  m.albedo = ReadMap(maps_dir / (albedo_file + ".tiff"));
  m.sd_albedo = ReadMap(maps_dir / ("sd_" + albedo_file + ".tiff"));
  m.normal = ReadMap(maps_dir / "normal.tiff");
  m.sd_normal = ReadMap(maps_dir / "sd_normal.tiff");
  m.materials = ReadMap(maps_dir / "materials.tiff");
  m.has_rough = fs::exists(maps_dir / "roughness.tiff");
  if (m.has_rough) {
    m.rough = ReadMap(maps_dir / "roughness.tiff");
    m.sd_rough = ReadMap(maps_dir / "sd_roughness.tiff");
  }
  m.mask = cv::imread((maps_dir / "mask.png").string(), cv::IMREAD_GRAYSCALE);
  if (m.mask.empty()) throw InputError((maps_dir / "mask.png").string() + ": cannot be read");
  m.edges = fs::exists(maps_dir / "edges.png")
                ? cv::imread((maps_dir / "edges.png").string(), cv::IMREAD_GRAYSCALE)
                : cv::Mat(m.mask.size(), CV_8U, cv::Scalar(0));
  m.materials_found = maps["clusters"]["k"].get<int>();
  return m;
}

struct Texel {
  double x, y;
  int i, j;
  bool interior, edge;
};

// The maps' masked texels with their board points; interior: no other truth material within
// the band and not an edge of the maps; edge: an edge of the maps the band leaves in.
std::vector<Texel> ClassifyTexels(const Maps& m, const Truth& truth, double band) {
  std::vector<Texel> texels;
  for (int j = 0; j < m.albedo.rows; ++j) {
    for (int i = 0; i < m.albedo.cols; ++i) {
      if (!m.mask.at<uint8_t>(j, i)) continue;
      const double x = m.x0 + i * m.texel + m.dx, y = m.y0 + j * m.texel + m.dy;
      const double m0 = truth.mat.At(x, y, 0, true);
      bool interior = true;
      for (int k = 0; k < 8 && interior; ++k) {
        const double a = k * kPi / 4;
        interior = truth.mat.At(x + band * std::cos(a), y + band * std::sin(a), 0, true) == m0;
      }
      const bool edge = m.edges.at<uint8_t>(j, i) > 0;
      texels.push_back({x, y, i, j, interior && !edge, interior && edge});
    }
  }
  return texels;
}

// Albedo scale per channel: least squares of fitted on true.
void FitAlbedoScale(const Maps& m, const Truth& truth, const std::vector<Texel>& texels,
                    MapsTruthComparison* r) {
  const int C = m.albedo.channels();
  for (int c = 0; c < C; ++c) {
    double num = 0, den = 0;
    for (const auto& t : texels) {
      const double a = truth.albedo.At(t.x, t.y, c);
      num += a * m.albedo.ptr<float>(t.j)[t.i * C + c];
      den += a * a;
    }
    r->albedo_scale[c] = den > 0 ? num / den : 1.0;
  }
}

// Sums of squared errors and z over the texels, by kind.
struct ErrorSums {
  double a2 = 0, a2_all = 0, az2 = 0, n2 = 0, n2_all = 0, nz2 = 0, r2 = 0, rz2 = 0;
  double ea2 = 0, eaz2 = 0;
  size_t na = 0, na_all = 0;
  std::map<std::pair<int, int>, size_t> confusion;  // (truth material, cluster) -> texels
};

// Texel t's errors into the sums (and r's texel counts).
void AddTexel(const Maps& m, const Truth& truth, const Texel& t, ErrorSums* s,
              MapsTruthComparison* r) {
  const int C = m.albedo.channels();
  ++r->texels;
  const float* a = m.albedo.ptr<float>(t.j) + t.i * C;
  const float* sa = m.sd_albedo.ptr<float>(t.j) + t.i * C;
  double ae2 = 0, az = 0;
  for (int c = 0; c < C; ++c) {
    const double truth_a = r->albedo_scale[c] * truth.albedo.At(t.x, t.y, C == 3 ? c : 1);
    const double e = a[c] - truth_a;
    ae2 += (e / truth_a) * (e / truth_a);
    az += sa[c] > 0 ? (e / sa[c]) * (e / sa[c]) : 0.0;
  }
  const float* nm = m.normal.ptr<float>(t.j) + t.i * 3;
  const Eigen::Vector3d nf(nm[0], nm[1], nm[2]);
  const Eigen::Vector3d nt =
      Eigen::Vector3d(truth.normal.At(t.x, t.y, 0), truth.normal.At(t.x, t.y, 1),
                      truth.normal.At(t.x, t.y, 2))
          .normalized();
  const double angle = RadToDeg(std::atan2(nf.cross(nt).norm(), nf.dot(nt)));
  s->a2_all += ae2;
  s->na_all += C;
  s->n2_all += angle * angle;
  if (t.edge) {
    ++r->edge;
    s->ea2 += ae2;
    s->eaz2 += az;
  }
  if (!t.interior) return;
  ++r->interior;
  s->a2 += ae2;
  s->na += C;
  s->az2 += az;
  s->n2 += angle * angle;
  const double sn = m.sd_normal.at<float>(t.j, t.i);
  if (sn > 0) s->nz2 += (angle / sn) * (angle / sn);
  if (m.has_rough) {
    const double e = m.rough.at<float>(t.j, t.i) - truth.rough.At(t.x, t.y, 0);
    s->r2 += e * e;
    const double sr = m.sd_rough.at<float>(t.j, t.i);
    if (sr > 0) s->rz2 += (e / sr) * (e / sr);
  }
  ++s->confusion[{static_cast<int>(std::lround(truth.mat.At(t.x, t.y, 0, true))),
                  static_cast<int>(std::lround(m.materials.at<float>(t.j, t.i)))}];
}

// Agreement: each found cluster counted for the truth material most of its texels have.
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

void MapsTruthOptions::Check() const {
  if (!(edge_band_m >= 0 && edge_band_m < 1)) {
    throw InputError(
        fmt::format("edge_band_m: {} is not a band in metres (0 <= band < 1)", edge_band_m));
  }
}

MapsTruthComparison CompareMapsWithTruth(const fs::path& maps_dir, const fs::path& truth_dir,
                                         const MapsTruthOptions& o) {
  o.Check();
  const nlohmann::json maps = ReadJsonFile(maps_dir / "maps.json");
  const nlohmann::json truth_json = ReadJsonFile(truth_dir / "truth.json");
  const Truth truth = ReadTruth(truth_dir, truth_json);
  const Maps m = ReadMaps(maps_dir, maps, truth_json);
  const int C = m.albedo.channels();
  MapsTruthComparison r;
  r.materials_found = m.materials_found;
  r.materials_true = truth.materials;
  const std::vector<Texel> texels = ClassifyTexels(m, truth, o.edge_band_m);
  if (o.fit_albedo_scale) FitAlbedoScale(m, truth, texels, &r);
  ErrorSums s;
  for (const auto& t : texels) AddTexel(m, truth, t, &s, &r);
  r.albedo_rel_rms = Rms(s.a2, s.na);
  r.albedo_rel_rms_all = Rms(s.a2_all, s.na_all);
  r.edge_albedo_rel_rms = Rms(s.ea2, r.edge * C);
  r.edge_albedo_rms_z = Rms(s.eaz2, r.edge * C);
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
