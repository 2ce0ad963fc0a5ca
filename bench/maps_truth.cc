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

MapsTruthComparison CompareMapsWithTruth(const fs::path& maps_dir, const fs::path& truth_dir,
                                         const MapsTruthOptions& o) {
  const nlohmann::json maps = ReadJsonFile(maps_dir / "maps.json");
  const nlohmann::json truth = ReadJsonFile(truth_dir / "truth.json");
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
  const TruthMap t_albedo = truth_map("albedo"), t_normal = truth_map("normal"),
                 t_rough = truth_map("roughness"), t_mat = truth_map("materials");
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
  const std::string channel_param = maps["channel_parameters"].get<std::string>();
  const std::string albedo_file = channel_param.rfind("diffuse", 0) == 0 ? "diffuse" : "albedo";
  const cv::Mat albedo = ReadMap(maps_dir / (albedo_file + ".tiff"));
  const cv::Mat sd_albedo = ReadMap(maps_dir / ("sd_" + albedo_file + ".tiff"));
  const cv::Mat normal = ReadMap(maps_dir / "normal.tiff");
  const cv::Mat sd_normal = ReadMap(maps_dir / "sd_normal.tiff");
  const cv::Mat materials = ReadMap(maps_dir / "materials.tiff");
  const bool has_rough = fs::exists(maps_dir / "roughness.tiff");
  const cv::Mat rough = has_rough ? ReadMap(maps_dir / "roughness.tiff") : cv::Mat();
  const cv::Mat sd_rough = has_rough ? ReadMap(maps_dir / "sd_roughness.tiff") : cv::Mat();
  const cv::Mat mask = cv::imread((maps_dir / "mask.png").string(), cv::IMREAD_GRAYSCALE);
  if (mask.empty()) throw InputError((maps_dir / "mask.png").string() + ": cannot be read");
  const cv::Mat edges = fs::exists(maps_dir / "edges.png")
                            ? cv::imread((maps_dir / "edges.png").string(), cv::IMREAD_GRAYSCALE)
                            : cv::Mat(mask.size(), CV_8U, cv::Scalar(0));
  const int C = albedo.channels();
  MapsTruthComparison r;
  r.materials_found = maps["clusters"]["k"].get<int>();
  r.materials_true = static_cast<int>(truth["texture"]["materials"].size());
  struct Texel {
    double x, y;
    int i, j;
    bool interior, edge;
  };
  std::vector<Texel> texels;
  const double band = o.edge_band_m;
  for (int j = 0; j < albedo.rows; ++j) {
    for (int i = 0; i < albedo.cols; ++i) {
      if (!mask.at<uint8_t>(j, i)) continue;
      const double x = x0 + i * texel + dx, y = y0 + j * texel + dy;
      const double m0 = t_mat.At(x, y, 0, true);
      bool interior = true;
      for (int k = 0; k < 8 && interior; ++k) {
        const double a = k * kPi / 4;
        interior = t_mat.At(x + band * std::cos(a), y + band * std::sin(a), 0, true) == m0;
      }
      const bool edge = edges.at<uint8_t>(j, i) > 0;
      texels.push_back({x, y, i, j, interior && !edge, interior && edge});
    }
  }
  // Albedo scale per channel (least squares of fitted on true) when asked.
  for (int c = 0; c < C && o.fit_albedo_scale; ++c) {
    double num = 0, den = 0;
    for (const auto& t : texels) {
      const double a = t_albedo.At(t.x, t.y, c);
      num += a * albedo.ptr<float>(t.j)[t.i * C + c];
      den += a * a;
    }
    r.albedo_scale[c] = den > 0 ? num / den : 1.0;
  }
  double a2 = 0, a2_all = 0, az2 = 0, n2 = 0, n2_all = 0, nz2 = 0, r2 = 0, rz2 = 0;
  double ea2 = 0, eaz2 = 0;
  size_t na = 0, na_all = 0;
  std::map<std::pair<int, int>, size_t> confusion;
  for (const auto& t : texels) {
    ++r.texels;
    const float* a = albedo.ptr<float>(t.j) + t.i * C;
    const float* sa = sd_albedo.ptr<float>(t.j) + t.i * C;
    double ae2 = 0, az = 0;
    for (int c = 0; c < C; ++c) {
      const double truth_a = r.albedo_scale[c] * t_albedo.At(t.x, t.y, C == 3 ? c : 1);
      const double e = a[c] - truth_a;
      ae2 += (e / truth_a) * (e / truth_a);
      az += sa[c] > 0 ? (e / sa[c]) * (e / sa[c]) : 0.0;
    }
    const float* nm = normal.ptr<float>(t.j) + t.i * 3;
    const Eigen::Vector3d nf(nm[0], nm[1], nm[2]);
    const Eigen::Vector3d nt = Eigen::Vector3d(t_normal.At(t.x, t.y, 0), t_normal.At(t.x, t.y, 1),
                                               t_normal.At(t.x, t.y, 2))
                                   .normalized();
    const double angle = RadToDeg(std::atan2(nf.cross(nt).norm(), nf.dot(nt)));
    a2_all += ae2;
    na_all += C;
    n2_all += angle * angle;
    if (t.edge) {
      ++r.edge;
      ea2 += ae2;
      eaz2 += az;
    }
    if (!t.interior) continue;
    ++r.interior;
    a2 += ae2;
    na += C;
    az2 += az;
    n2 += angle * angle;
    const double sn = sd_normal.at<float>(t.j, t.i);
    if (sn > 0) nz2 += (angle / sn) * (angle / sn);
    if (has_rough) {
      const double e = rough.at<float>(t.j, t.i) - t_rough.At(t.x, t.y, 0);
      r2 += e * e;
      const double s = sd_rough.at<float>(t.j, t.i);
      if (s > 0) rz2 += (e / s) * (e / s);
    }
    ++confusion[{static_cast<int>(std::lround(t_mat.At(t.x, t.y, 0, true))),
                 static_cast<int>(std::lround(materials.at<float>(t.j, t.i)))}];
  }
  r.albedo_rel_rms = Rms(a2, na);
  r.albedo_rel_rms_all = Rms(a2_all, na_all);
  r.edge_albedo_rel_rms = Rms(ea2, r.edge * C);
  r.edge_albedo_rms_z = Rms(eaz2, r.edge * C);
  r.albedo_rms_z = Rms(az2, na);
  r.normal_rms_deg = Rms(n2, r.interior);
  r.normal_rms_deg_all = Rms(n2_all, r.texels);
  r.normal_rms_z = Rms(nz2, r.interior);
  r.roughness_rms = Rms(r2, r.interior);
  r.roughness_rms_deg = RadToDeg(r.roughness_rms);
  r.roughness_rms_z = Rms(rz2, r.interior);
  // Agreement: each found cluster counted for the truth material most of its texels have.
  std::map<int, std::pair<int, size_t>> best;  // cluster -> (material, count)
  for (const auto& [key, count] : confusion) {
    auto& b = best[key.second];
    if (count > b.second) b = {key.first, count};
  }
  size_t agree = 0;
  for (const auto& [cluster, b] : best) agree += b.second;
  r.material_agreement = r.interior ? static_cast<double>(agree) / r.interior : 0.0;
  return r;
}

}  // namespace gonio::bench
