#include "estimation/sfs/sfs_io.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/parse.h"
#include "common/plot.h"
#include "common/stats.h"
#include "estimation/fit/fit_file.h"
#include "reflectance/registry.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

using json = nlohmann::json;

Eigen::Vector3d ParseLamp(const std::string& s) {
  if (s == "collocated") return Eigen::Vector3d::Zero();
  return ParseVector3(s, "--lamp (X,Y,Z metres in the camera frame, or collocated)");
}

}  // namespace

void SfsInputPaths::FillFromFolder(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw InputError("--input: '" + dir.string() + "' is not a folder");
  if (image.empty()) image = dir / "image.png";
  if (camera.empty()) camera = dir / "camera.cameramodel";
  if (material.empty()) material = dir / "material.json";
  if (mask.empty()) mask = dir / "mask.png";
  // lamp.json, or light.json in folders rendered before the lamp's file was renamed.
  for (const char* name : {"lamp.json", "light.json"}) {
    if (lamp_json.empty() && fs::exists(dir / name)) lamp_json = dir / name;
  }
  if (truth_dir.empty()) truth_dir = dir;
}

namespace {

// The lamp from lamp.json and/or --lamp (which overrides the position), and the radiometry
// lamp.json may carry: radiance_per_dn (absolute radiance), black level, intensity.
void ReadLamp(const SfsInputPaths& paths, SfsInput* in) {
  SfsProblem& pr = in->problem;
  bool have_lamp = false;
  if (!paths.lamp_json.empty()) {
    const json l = ReadJsonFile(paths.lamp_json);
    if (l.contains("position")) {
      const auto& p = l["position"];
      if (!p.is_array() || p.size() != 3) {
        throw InputError(paths.lamp_json.string() + ": 'position' is not [x, y, z]");
      }
      pr.lamp_in_cam = {p[0].get<double>(), p[1].get<double>(), p[2].get<double>()};
      have_lamp = true;
    }
    if (l.value("frame", std::string("camera")) != "camera") {
      throw InputError(paths.lamp_json.string() + ": only frame 'camera' lamps are supported");
    }
    pr.lamp_intensity = l.value("intensity", 1.0);
    if (l.contains("radiance_per_dn")) {
      in->radiance_per_dn = l["radiance_per_dn"].get<double>();
      in->black_level = l.value("black_level", 0.0);
      in->absolute = l.contains("intensity");
    }
  }
  if (!paths.lamp.empty()) {
    pr.lamp_in_cam = ParseLamp(paths.lamp);
    have_lamp = true;
  }
  if (!have_lamp) throw InputError("--lamp: required (X,Y,Z or collocated) without lamp.json");
  if (!(in->radiance_per_dn > 0)) {
    throw InputError(paths.lamp_json.string() + ": radiance_per_dn must be > 0");
  }
}

// The object distance: --distance, else from absolute radiometry and the material. The
// brightest 3x3 mean inside the mask is read as the material at normal incidence facing the
// lamp: L = I f_r(0, 0, 0) / z^2 (exact for a collocated lamp at the surface point facing it; an
// estimate of the object distance otherwise).
void SetAnchorDepth(const SfsInputPaths& paths, bool have_material, SfsInput* in) {
  SfsProblem& pr = in->problem;
  if (paths.distance > 0) {
    pr.anchor_depth = paths.distance;
    in->anchor_source = "--distance";
  } else if (in->absolute && have_material && !pr.mask.empty() &&
             pr.mask.size() == pr.radiance.size()) {
    cv::Mat blurred;
    cv::blur(pr.radiance, blurred, cv::Size(3, 3));
    cv::Mat eroded;
    cv::erode(pr.mask, eroded, cv::Mat::ones(3, 3, CV_8U));
    double lmax = 0;
    cv::minMaxLoc(blurred, nullptr, &lmax, nullptr, nullptr, eroded);
    double f0 = 0;
    EvaluateChecked(pr.model, pr.params, Angles<double>{0, 0, 0}, &f0);
    if (lmax > 0 && f0 > 0) pr.anchor_depth = std::sqrt(pr.lamp_intensity * f0 / lmax);
    in->anchor_source = "absolute radiometry: z = sqrt(I f_r(0,0,0) / L_max)";
  }
  if (!(pr.anchor_depth > 0)) {
    throw InputError(
        "--distance: required (object distance in metres) when the radiance is not absolute "
        "(no radiance_per_dn in lamp.json) or no material is given");
  }
}

}  // namespace

namespace {

// The object's mask (non-zero inside): grey or colour, the image's size, and a region the solver
// can work on (at least one pixel whose 3x3 neighbourhood is inside, where the distance anchor
// is read), else InputError naming the mask.
cv::Mat ReadMask(const fs::path& path, const cv::Size& image_size, const fs::path& image) {
  ImageExpectation expect;
  expect.size = image_size;
  expect.size_of = "the image " + image.string();
  expect.alpha = ImageExpectation::Alpha::kDrop;
  cv::Mat m = ReadImage(path, expect);
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
  if (m.depth() == CV_16U) m.convertTo(m, CV_8U, 1.0 / 257);
  const cv::Mat inside = m > 127;
  cv::Mat interior;
  cv::erode(inside, interior, cv::Mat::ones(3, 3, CV_8U));
  if (cv::countNonZero(interior) == 0) {
    throw InputError(fmt::format(
        "{}: {} pixel(s) inside the mask and none with its 3x3 neighbourhood inside; shape from "
        "shading needs the object's region (non-zero inside)",
        path.string(), cv::countNonZero(inside)));
  }
  return m;
}

// Clipped pixels carry no shading: a mask with more than 0.1% of its pixels at the white level
// (lamp.json's "white_level", else the container's maximum) is refused, not solved into a
// wrong shape.
void CheckNotSaturated(const cv::Mat& image, const cv::Mat& mask, const SfsInputPaths& paths) {
  if (image.depth() != CV_8U && image.depth() != CV_16U) return;
  double white = image.depth() == CV_8U ? 255 : 65535;
  if (!paths.lamp_json.empty()) white = ReadJsonFile(paths.lamp_json).value("white_level", white);
  const int in_mask = cv::countNonZero(mask);
  const int clipped = cv::countNonZero((image >= white) & mask);
  if (in_mask > 0 && clipped > 0.001 * in_mask) {
    throw InputError(
        fmt::format("{}: {:.1f}% of the object's pixels are saturated (at {}): "
                    "shape from shading needs unclipped shading; shoot a shorter "
                    "exposure",
                    paths.image.string(), 100.0 * clipped / in_mask, white));
  }
}

}  // namespace

SfsInput LoadSfsInput(const SfsInputPaths& paths, const std::string& reflectance) {
  SfsInput in;
  SfsProblem& pr = in.problem;
  if (paths.image.empty()) throw InputError("--image: required (or --input DIR)");
  if (paths.camera.empty()) throw InputError("--camera: required (or --input DIR)");
  if (paths.mask.empty()) throw InputError("--mask: required (or --input DIR)");
  in.image_path = paths.image.string();
  cv::Mat image = ReadImage(paths.image);
  if (image.channels() == 3) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2GRAY);
  const cv::Mat mask = ReadMask(paths.mask, image.size(), paths.image);
  pr.camera = CameraModel::Read(paths.camera);
  ReadLamp(paths, &in);

  image.convertTo(pr.radiance, CV_64F);
  pr.radiance = (pr.radiance - in.black_level) * in.radiance_per_dn;
  cv::max(pr.radiance, 0.0, pr.radiance);
  pr.mask = mask > 127;
  CheckNotSaturated(image, pr.mask, paths);

  const bool have_material = !paths.material.empty() && fs::exists(paths.material);
  pr.absolute = in.absolute && have_material && reflectance == "material";
  if (have_material) {
    // The fitted material (estimation/fit/fit_file.h, the same reader gonio export uses); a
    // relative fit is accepted: shape from shading with absolute radiometry says so itself.
    ReadFitOptions ro;
    ro.allow_relative = true;
    const FittedMaterial m = ReadFitFile(paths.material, ro);
    pr.model = m.model;
    pr.params = m.params;
  } else if (reflectance == "lambert") {
    pr.model = "lambert";
    pr.params = {1.0};
  } else {
    throw InputError("--material: " + (paths.material.empty()
                                           ? std::string("required for --reflectance material")
                                           : paths.material.string() + " not found"));
  }
  SetAnchorDepth(paths, have_material, &in);
  return in;
}

std::optional<SfsTruthComparison> CompareWithTruth(const fs::path& dir, const SfsInput& input,
                                                   const SfsResult& result) {
  if (dir.empty() || !fs::exists(dir / "normals.tiff") || !fs::exists(dir / "depth.tiff")) {
    return std::nullopt;
  }
  SfsTruthComparison t;
  ImageExpectation any;
  any.pixels = ImageExpectation::Pixels::kAny;
  cv::Mat n = ReadImage(dir / "normals.tiff", any);
  cv::Mat d = ReadImage(dir / "depth.tiff", any);
  if (n.channels() != 3 || d.channels() != 1 || n.size() != result.depth.size() ||
      d.size() != result.depth.size()) {
    throw InputError((dir / "normals.tiff").string() + ": size or channels do not match");
  }
  // The TIFF stores RGB = (x, y, z); OpenCV returns BGR.
  cv::cvtColor(n, n, cv::COLOR_BGR2RGB);
  n.convertTo(t.normals, CV_64FC3);
  d.convertTo(t.depth, CV_64F);
  std::vector<double> errors, depth_errors;
  const cv::Mat& mask = input.problem.mask;
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (!mask.at<uint8_t>(y, x)) continue;
      const cv::Vec3d a = t.normals.at<cv::Vec3d>(y, x), b = result.normals.at<cv::Vec3d>(y, x);
      const double na = cv::norm(a), nb = cv::norm(b);
      const double zt = t.depth.at<double>(y, x);
      if (na < 0.5 || nb < 0.5 || !(zt > 0)) continue;
      const double c = std::clamp(a.dot(b) / (na * nb), -1.0, 1.0);
      errors.push_back(std::acos(c) * 180.0 / M_PI);
      depth_errors.push_back(std::abs(result.depth.at<double>(y, x) - zt) / zt);
    }
  }
  if (errors.empty()) throw InputError(dir.string() + ": truth has no pixels inside the mask");
  double sum = 0;
  for (double e : errors) sum += e;
  t.pixels = errors.size();
  t.mean_normal_error_deg = sum / errors.size();
  t.p95_normal_error_deg = Percentile(errors, 0.95);
  t.median_normal_error_deg = Percentile(errors, 0.5);
  t.median_depth_error_rel = Percentile(depth_errors, 0.5);
  return t;
}

namespace {

// depth.tiff (float32 metres), normals.png (RGB = (n + 1) / 2), rerender.png (16-bit, the
// input's pixel units).
void WriteMaps(const fs::path& out, const SfsInput& input, const SfsResult& result) {
  const cv::Mat& mask = input.problem.mask;
  cv::Mat depth32;
  result.depth.convertTo(depth32, CV_32F);
  WriteImage(out / "depth.tiff", depth32);
  cv::Mat normals8(result.normals.size(), CV_8UC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < normals8.rows; ++y) {
    for (int x = 0; x < normals8.cols; ++x) {
      if (!mask.at<uint8_t>(y, x)) continue;
      const cv::Vec3d n = result.normals.at<cv::Vec3d>(y, x);
      auto c = [](double v) { return cv::saturate_cast<uint8_t>((v + 1) * 127.5); };
      normals8.at<cv::Vec3b>(y, x) = cv::Vec3b(c(n[2]), c(n[1]), c(n[0]));  // OpenCV writes BGR
    }
  }
  WriteImage(out / "normals.png", normals8);
  cv::Mat rerender(result.rendered.size(), CV_16U, cv::Scalar(0));
  for (int y = 0; y < rerender.rows; ++y) {
    for (int x = 0; x < rerender.cols; ++x) {
      rerender.at<uint16_t>(y, x) = cv::saturate_cast<uint16_t>(
          result.rendered.at<double>(y, x) / input.radiance_per_dn + input.black_level);
    }
  }
  WriteImage(out / "rerender.png", rerender);
}

// normal_error.png: angular error per pixel, 0 (black) .. 30 deg (white) and beyond, so where
// the shape goes wrong (contour, shadow, a flipped region) is seen at a glance.
void WriteNormalError(const fs::path& out, const cv::Mat& mask, const SfsResult& result,
                      const SfsTruthComparison& truth) {
  cv::Mat err8(mask.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < err8.rows; ++y) {
    for (int x = 0; x < err8.cols; ++x) {
      if (!mask.at<uint8_t>(y, x)) continue;
      const cv::Vec3d a = truth.normals.at<cv::Vec3d>(y, x);
      const cv::Vec3d b = result.normals.at<cv::Vec3d>(y, x);
      const double na = cv::norm(a), nb = cv::norm(b);
      if (na < 0.5 || nb < 0.5) continue;
      const double deg = std::acos(std::clamp(a.dot(b) / (na * nb), -1.0, 1.0)) * 180 / M_PI;
      err8.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(1 + deg * 254.0 / 30.0);
    }
  }
  cv::Mat colour;
  cv::applyColorMap(err8, colour, cv::COLORMAP_INFERNO);
  colour.setTo(cv::Scalar(0, 0, 0), ~mask);
  WriteImage(out / "normal_error.png", colour);
}

// The curves along one image row: brightness (measured, re-rendered, and with truth the
// material and the best Lambertian albedo on the true shape) and depth (recovered, truth, and
// the Lambertian prior's of a comparison).
struct RowSections {
  PlotSeries measured{"measured", {}, {}, "lines lw 2"};
  PlotSeries rendered;
  PlotSeries lambert_truth{"Lambertian on the true shape (best albedo)", {}, {}, "lines lw 1"};
  PlotSeries material_truth;
  PlotSeries depth_lambert{"recovered with a Lambertian prior", {}, {}, "lines lw 2 dt 4"};
  PlotSeries depth_est{"recovered", {}, {}, "lines lw 2"};
  PlotSeries depth_true{"truth", {}, {}, "lines lw 2 dt 2"};
};

RowSections SectionsAlongRow(int row, const SfsInput& input, const SfsResult& result,
                             const std::optional<SfsTruthComparison>& truth,
                             const SfsLambertComparison* comparison) {
  const SfsProblem& pr = input.problem;
  RowSections c;
  c.rendered = {
      "re-rendered (recovered shape, " + result.reflectance + ")", {}, {}, "lines lw 2 dt 2"};
  c.material_truth = {"material (" + pr.model + ") on the true shape", {}, {}, "lines lw 1 dt 3"};
  std::vector<double> lt_raw;
  for (int x = 0; x < pr.mask.cols; ++x) {
    if (!pr.mask.at<uint8_t>(row, x)) continue;
    c.measured.x.push_back(x);
    c.measured.y.push_back(pr.radiance.at<double>(row, x));
    c.rendered.x.push_back(x);
    c.rendered.y.push_back(result.rendered.at<double>(row, x));
    c.depth_est.x.push_back(x);
    c.depth_est.y.push_back(result.depth.at<double>(row, x) * 1e3);
    if (comparison) {
      c.depth_lambert.x.push_back(x);
      c.depth_lambert.y.push_back(comparison->lambert.depth.at<double>(row, x) * 1e3);
    }
    if (!truth) continue;
    const cv::Vec3d n = truth->normals.at<cv::Vec3d>(row, x);
    const double z = truth->depth.at<double>(row, x);
    if (!(z > 0)) continue;
    const Eigen::Vector3d ray = pr.camera.Unproject(Eigen::Vector2d(x, row));
    const Eigen::Vector3d normal(n[0], n[1], n[2]), point = ray / ray.z() * z;
    c.lambert_truth.x.push_back(x);
    lt_raw.push_back(SfsRadiance(pr, "lambert", 1.0, normal, point));
    c.lambert_truth.y.push_back(pr.radiance.at<double>(row, x));
    c.material_truth.x.push_back(x);
    c.material_truth.y.push_back(SfsRadiance(
        pr, "material", result.reflectance == "material" ? result.scale : 1.0, normal, point));
    c.depth_true.x.push_back(x);
    c.depth_true.y.push_back(z * 1e3);
  }
  // Best Lambertian albedo for the true shape along the row (least squares).
  double num = 0, den = 0;
  for (size_t i = 0; i < lt_raw.size(); ++i) {
    num += lt_raw[i] * c.lambert_truth.y[i];
    den += lt_raw[i] * lt_raw[i];
  }
  for (size_t i = 0; i < lt_raw.size(); ++i) {
    c.lambert_truth.y[i] = den > 0 ? lt_raw[i] * num / den : 0;
  }
  return c;
}

// cross_section.png, depth_section.png and, with a comparison, comparison_depth.png along the
// middle row of the object's bounding box (Oren-Nayar fig. 23); returns that row.
int WriteSections(const fs::path& out, const SfsInput& input, const SfsResult& result,
                  const std::optional<SfsTruthComparison>& truth,
                  const SfsLambertComparison* comparison) {
  const cv::Rect box = cv::boundingRect(input.problem.mask);
  const int row = box.y + box.height / 2;
  RowSections c = SectionsAlongRow(row, input, result, truth, comparison);
  PlotSpec bright;
  bright.title = "Brightness along row " + std::to_string(row);
  bright.xlabel = "image column (px)";
  bright.ylabel = input.absolute ? "radiance (W m^-2 sr^-1)" : "relative radiance";
  bright.series = {c.measured, c.rendered};
  if (truth && input.absolute) bright.series.push_back(c.material_truth);
  if (truth) bright.series.push_back(c.lambert_truth);
  bright.extra = "set key bottom center";
  RenderPlot(bright, out / "cross_section.png");
  PlotSpec dplot;
  dplot.title = "Depth along row " + std::to_string(row);
  dplot.xlabel = "image column (px)";
  dplot.ylabel = "camera-frame z (mm)";
  dplot.series = {c.depth_est};
  if (truth) dplot.series.push_back(c.depth_true);
  dplot.extra = "set yrange [*:*] reverse\nset key top center";
  RenderPlot(dplot, out / "depth_section.png");
  if (comparison) {
    // Oren-Nayar's point (figs. 22-23) on the recovered shape: under a collocated lamp the rough
    // object looks flat, and a Lambertian prior turns that flatness into a flatter shape.
    PlotSpec cplot = dplot;
    c.depth_est.label = "recovered with the material prior (" + input.problem.model + ")";
    cplot.title = "Depth along row " + std::to_string(row) + ": material vs Lambertian prior";
    cplot.series = {c.depth_est, c.depth_lambert};
    if (truth) cplot.series.push_back(c.depth_true);
    RenderPlot(cplot, out / "comparison_depth.png");
  }
  return row;
}

json ComparisonJson(const SfsLambertComparison& comparison,
                    const std::optional<SfsTruthComparison>& truth) {
  const SfsResult& lr = comparison.lambert;
  json c = {{"reflectance", "lambert"},
            {"outputs", "lambert/"},
            {"scale_k", lr.scale},
            {"residual_rms_relative", lr.rms_relative_residual},
            {"seconds", lr.seconds}};
  if (comparison.truth) {
    c["mean_normal_error_deg"] = comparison.truth->mean_normal_error_deg;
    c["p95_normal_error_deg"] = comparison.truth->p95_normal_error_deg;
    if (truth && truth->mean_normal_error_deg > 0) {
      c["mean_error_ratio_lambert_over_material"] =
          comparison.truth->mean_normal_error_deg / truth->mean_normal_error_deg;
    }
  }
  return c;
}

// sfs.json (docs/sfs.md); its keys keep the names "lamp_in_camera" and "lamp_intensity".
json SfsJson(const SfsInput& input, const SfsResult& result,
             const std::optional<SfsTruthComparison>& truth, const SfsLambertComparison* comparison,
             int row) {
  const SfsProblem& pr = input.problem;
  json j = {
      {"format", "gonio-sfs"},
      {"version", 1},
      {"image", input.image_path},
      {"reflectance", result.reflectance},
      {"material", {{"model", pr.model}, {"params", pr.params}}},
      {"lamp_in_camera", {pr.lamp_in_cam.x(), pr.lamp_in_cam.y(), pr.lamp_in_cam.z()}},
      {"lamp_intensity", pr.lamp_intensity},
      {"radiance_absolute", input.absolute},
      {"scale_k", result.scale},
      {"scale_meaning",
       result.reflectance == "lambert"
           ? "fitted Lambertian albedo (times lamp intensity / exposure error if any)"
           : "fitted factor on the material BRDF (1 = radiance, lamp and material exact)"},
      {"anchor_depth_m", pr.anchor_depth},
      {"anchor_source", input.anchor_source},
      {"residual_rms_relative", result.rms_relative_residual},
      {"median_radiance", result.median_radiance},
      {"noise_relative", result.noise_relative},
      {"smoothness_used", result.smoothness},
      {"mask_pixels", result.mask_pixels},
      {"levels", result.levels},
      {"iterations", result.iterations},
      {"seconds", result.seconds},
      {"cross_section_row", row},
      {"files",
       {"depth.tiff", "normals.png", "rerender.png", "cross_section.png", "depth_section.png"}}};
  if (truth) j["files"].push_back("normal_error.png");
  if (comparison) {
    j["files"].push_back("comparison_depth.png");
    j["comparison"] = ComparisonJson(*comparison, truth);
  }
  if (truth) {
    j["mean_normal_error_deg"] = truth->mean_normal_error_deg;
    j["p95_normal_error_deg"] = truth->p95_normal_error_deg;
    j["median_normal_error_deg"] = truth->median_normal_error_deg;
    j["median_depth_error_relative"] = truth->median_depth_error_rel;
    j["truth_pixels"] = truth->pixels;
  }
  return j;
}

}  // namespace

json WriteSfsOutputs(const fs::path& out, const SfsInput& input, const SfsResult& result,
                     const std::optional<SfsTruthComparison>& truth,
                     const SfsLambertComparison* comparison) {
  EnsureDirectory(out);
  WriteMaps(out, input, result);
  if (truth) WriteNormalError(out, input.problem.mask, result, *truth);
  const int row = WriteSections(out, input, result, truth, comparison);
  const json j = SfsJson(input, result, truth, comparison, row);
  WriteJsonAtomically(out / "sfs.json", j);
  return j;
}

}  // namespace gonio
