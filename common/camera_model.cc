#include "common/camera_model.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <optional>
#include <regex>
#include <sstream>
#include <utility>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "common/error.h"
#include "common/io.h"

namespace gonio {
namespace {

// The line CalibrationRmsLine writes (a comment, which mrcal's reader skips).
constexpr const char* kRmsPattern =
    R"(#\s*gonio: calibration RMS reprojection error ([0-9.eE+-]+) px)";

}  // namespace

namespace {
constexpr std::pair<LensModel, const char*> kLensModelNames[] = {
    {LensModel::kPinhole, "LENSMODEL_PINHOLE"},
    {LensModel::kOpenCV4, "LENSMODEL_OPENCV4"},
    {LensModel::kOpenCV5, "LENSMODEL_OPENCV5"},
    {LensModel::kOpenCV8, "LENSMODEL_OPENCV8"}};
}  // namespace

LensModel ParseLensModel(const std::string& mrcal_name) {
  for (const auto& [model, name] : kLensModelNames) {
    if (mrcal_name == name) return model;
  }
  throw InputError("lens model '" + mrcal_name +
                   "' is not supported (LENSMODEL_PINHOLE, LENSMODEL_OPENCV4/5/8)");
}

const char* LensModelName(LensModel model) {
  for (const auto& [m, name] : kLensModelNames) {
    if (m == model) return name;
  }
  return "?";  // only a cast can produce another value
}

int CameraModel::NumIntrinsics(LensModel lens_model) {
  switch (lens_model) {
    case LensModel::kPinhole:
      return 4;
    case LensModel::kOpenCV4:
      return 8;
    case LensModel::kOpenCV5:
      return 9;
    case LensModel::kOpenCV8:
      return 12;
  }
  return 4;
}

Eigen::Vector2d CameraModel::Project(const Eigen::Vector3d& p_in_cam) const {
  double px[2];
  Project(p_in_cam.data(), px);
  return {px[0], px[1]};
}

Eigen::Vector3d CameraModel::Unproject(const Eigen::Vector2d& pixel) const {
  // Gauss-Newton on the normalized coordinates with a numeric Jacobian; converges in a few
  // steps for the distortions cameras have. Starts from the pinhole solution.
  const double fx = intrinsics[0], fy = intrinsics[1], cx = intrinsics[2], cy = intrinsics[3];
  Eigen::Vector2d xy((pixel.x() - cx) / fx, (pixel.y() - cy) / fy);
  if (lens_model == LensModel::kPinhole) return {xy.x(), xy.y(), 1.0};
  for (int it = 0; it < 30; ++it) {
    auto f = [&](const Eigen::Vector2d& q) { return Project(Eigen::Vector3d(q.x(), q.y(), 1.0)); };
    const Eigen::Vector2d r = f(xy) - pixel;
    if (r.norm() < 1e-10) break;
    Eigen::Matrix2d J;
    const double h = 1e-7;
    for (int c = 0; c < 2; ++c) {
      Eigen::Vector2d dq = Eigen::Vector2d::Zero();
      dq[c] = h;
      J.col(c) = (f(xy + dq) - f(xy - dq)) / (2 * h);
    }
    xy -= J.colPivHouseholderQr().solve(r);
  }
  return {xy.x(), xy.y(), 1.0};
}

namespace {

// mrcal writes a Python dict literal: drop comments, single -> double quotes, drop trailing
// commas, and it is JSON.
std::string PythonDictAsJson(const std::string& text) {
  std::string cleaned;
  bool in_string = false;
  char quote = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      cleaned += (c == quote) ? '"' : c;
      if (c == quote) in_string = false;
    } else if (c == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
      cleaned += '\n';
    } else if (c == '\'' || c == '"') {
      // mrcal stores optimization_inputs as a Python bytes literal b'...' (base-85 text).
      if (!cleaned.empty() && cleaned.back() == 'b' &&
          (cleaned.size() == 1 ||
           std::isspace(static_cast<unsigned char>(cleaned[cleaned.size() - 2])) ||
           cleaned[cleaned.size() - 2] == ':')) {
        cleaned.pop_back();
      }
      in_string = true;
      quote = c;
      cleaned += '"';
    } else {
      cleaned += c;
    }
  }
  return std::regex_replace(cleaned, std::regex(",(\\s*[\\]\\}])"), "$1");
}

// The lens model, intrinsics, size and (when there are six values) extrinsics of the parsed
// file, unchecked.
CameraModel ModelFromJson(const nlohmann::json& j, const std::filesystem::path& path) {
  CameraModel m;
  try {
    const std::string lens_model = j.at("lensmodel").get<std::string>();
    try {
      m.lens_model = ParseLensModel(lens_model);
    } catch (const InputError& e) {
      throw InputError(path.string() + ": " + e.what());
    }
    m.intrinsics = j.at("intrinsics").get<std::vector<double>>();
    const auto size = j.at("imagersize").get<std::vector<int>>();
    if (size.size() != 2) throw InputError(path.string() + ": imagersize must have 2 values");
    m.width = size[0];
    m.height = size[1];
    if (j.contains("extrinsics")) {
      const auto rt = j["extrinsics"].get<std::vector<double>>();
      if (rt.size() == 6) {
        const Eigen::Vector3d r(rt[0], rt[1], rt[2]);
        const double angle = r.norm();
        m.cam_from_ref.R = angle > 0 ? Eigen::AngleAxisd(angle, r / angle).toRotationMatrix()
                                     : Eigen::Matrix3d::Identity();
        m.cam_from_ref.t = Eigen::Vector3d(rt[3], rt[4], rt[5]);
      }
    }
  } catch (const nlohmann::json::exception&) {
    throw InputError(path.string() + ": .cameramodel lacks lensmodel, intrinsics or imagersize");
  }
  return m;
}

void CheckModel(const CameraModel& m, const std::filesystem::path& path) {
  const int n = CameraModel::NumIntrinsics(m.lens_model);
  if (static_cast<int>(m.intrinsics.size()) != n) {
    throw InputError(path.string() + ": " + LensModelName(m.lens_model) + " needs " +
                     std::to_string(n) + " intrinsics, file has " +
                     std::to_string(m.intrinsics.size()));
  }
  // A focal length <= 0 mirrors or collapses every projection (poses come out mirrored, or
  // the solvers divide by zero): no camera has one.
  if (!m.IntrinsicsFinite() || !(m.intrinsics[0] > 0) || !(m.intrinsics[1] > 0)) {
    throw InputError(fmt::format("{}: focal lengths fx = {}, fy = {}; they must be finite and > 0",
                                 path.string(), m.intrinsics[0], m.intrinsics[1]));
  }
  if (m.width <= 0 || m.height <= 0) {
    throw InputError(
        fmt::format("{}: imagersize {}x{} must be positive", path.string(), m.width, m.height));
  }
  if (!m.cam_from_ref.R.allFinite() || !m.cam_from_ref.t.allFinite()) {
    throw InputError(path.string() + ": extrinsics are not finite");
  }
}

// The RMS of the comment line CalibrationRmsLine writes, when the file has one with a finite
// positive number.
std::optional<double> CalibrationRmsOf(const std::string& text) {
  std::smatch rms;
  if (std::regex_search(text, rms, std::regex(kRmsPattern))) {
    const std::string number = rms[1];
    char* end = nullptr;
    const double v = std::strtod(number.c_str(), &end);
    if (end == number.c_str() + number.size() && std::isfinite(v) && v > 0) return v;
  }
  return std::nullopt;
}

}  // namespace

CameraModel CameraModel::Read(const std::filesystem::path& path) {
  const std::string text = ReadTextFile(path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(PythonDictAsJson(text));
  } catch (const nlohmann::json::exception&) {  // syntax, or a number out of range (1e999)
    throw InputError(path.string() + ": not a readable mrcal .cameramodel");
  }
  CameraModel m = ModelFromJson(j, path);
  CheckModel(m, path);
  m.calibration_rms_px = CalibrationRmsOf(text);
  return m;
}

std::string CameraModel::CalibrationRmsLine(double rms_px) {
  return fmt::format("# gonio: calibration RMS reprojection error {:.4g} px\n", rms_px);
}

void CameraModel::Write(const std::filesystem::path& path, const std::string& comment) const {
  std::ostringstream s;
  s << std::setprecision(17);
  s << "# generated by gonio";
  if (!comment.empty()) s << ": " << comment;
  s << "\n";
  if (calibration_rms_px) s << CalibrationRmsLine(*calibration_rms_px);
  s << "{\n    'lensmodel':  '" << LensModelName(lens_model) << "',\n";
  s << "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....\n";
  s << "    'intrinsics': [ ";
  for (double v : intrinsics) s << v << ", ";
  s << "],\n";
  const Eigen::AngleAxisd aa(cam_from_ref.R);
  const Eigen::Vector3d r = aa.angle() * aa.axis();
  s << "    # extrinsics are rt_fromref\n";
  s << "    'extrinsics': [ " << r.x() << ", " << r.y() << ", " << r.z() << ", "
    << cam_from_ref.t.x() << ", " << cam_from_ref.t.y() << ", " << cam_from_ref.t.z() << ", ],\n";
  s << "    'imagersize': [ " << width << ", " << height << " ],\n}\n";
  WriteTextAtomically(path, s.str());
}

}  // namespace gonio
