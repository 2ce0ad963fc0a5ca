// Shared pieces of the photometric tests: small synthetic scenes from the data_synth presets,
// and the truth response/vignetting those presets render with.
#pragma once

#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/photometric.h"
#include "calib/photometry/vignette.h"
#include "common/io.h"
#include "common/session.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"

namespace gonio::testing {

// A preset with the camera shrunk by `div` (same field of view and distortion), so renders take
// a fraction of a second.
inline synth::Scene SmallPreset(const std::string& preset, int div) {
  synth::Scene s = synth::PresetScene(preset);
  s.camera.width /= div;
  s.camera.height /= div;
  s.camera.intrinsics[0] /= div;
  s.camera.intrinsics[1] /= div;
  s.camera.intrinsics[2] = (s.camera.intrinsics[2] + 0.5) / div - 0.5;
  s.camera.intrinsics[3] = (s.camera.intrinsics[3] + 0.5) / div - 0.5;
  s.supersampling = 2;
  return s;
}

// The inverse of the scene's response (gamma only), scaled so X = 1 is full well.
inline PhotometricCalibration TruthCalibration(const synth::Scene& s, int channels = 1) {
  const auto& p = s.photometric;
  PhotometricCalibration c = PhotometricCalibration::Linear(p.bit_depth, channels, p.black_level,
                                                            BlackLevelSource::kOption);
  const double maxv = (1 << p.bit_depth) - 1.0;
  for (int ch = 0; ch < channels; ++ch) {
    for (size_t z = 0; z < c.response.inverse_response[ch].size(); ++z) {
      const double f = std::max(0.0, (z - p.black_level) / (maxv - p.black_level));
      c.response.inverse_response[ch][z] = p.response == synth::ResponseCurve::kGamma
                                               ? std::pow(f, p.gamma)
                                               : f;  // linear otherwise
    }
  }
  c.read_noise_dn = p.read_noise_e / p.full_well_e * (maxv - p.black_level);
  return c;
}

// V(x, y) = 1 + v1 r^2 + v2 r^4 + v3 r^6 with r the distance to the principal point over half
// the image diagonal, as docs/photometric.md defines the scene's vignetting. Written out here,
// not taken from common/vignetting.h: the renderer and the radial fit both use that one, so a
// mistake in it would otherwise be in the truth as well and no test could see it.
inline double DocsVignetting(const CameraModel& camera, const std::array<double, 3>& v, double x,
                             double y) {
  const double dx = x - camera.intrinsics[2], dy = y - camera.intrinsics[3];
  const double half_diagonal = 0.5 * std::hypot(camera.width, camera.height);
  const double r = std::hypot(dx, dy) / half_diagonal;
  return 1 + v[0] * std::pow(r, 2) + v[1] * std::pow(r, 4) + v[2] * std::pow(r, 6);
}

inline cv::Mat TruthVignette(const synth::Scene& s) {
  cv::Mat m(s.camera.height, s.camera.width, CV_32F);
  const std::array<double, 3> v = {s.photometric.vignetting[0], s.photometric.vignetting[1],
                                   s.photometric.vignetting[2]};
  for (int y = 0; y < m.rows; ++y) {
    for (int x = 0; x < m.cols; ++x) m.at<float>(y, x) = DocsVignetting(s.camera, v, x, y);
  }
  return m;
}

// poses.json in gonio locate's layout from the truth poses of a rendered session; `max_poses`
// keeps the first few.
inline void WriteTruthPoses(const std::filesystem::path& session_dir,
                            const std::filesystem::path& out, size_t max_poses = 1000) {
  const nlohmann::json truth = ReadJsonFile(session_dir / "truth.json");
  nlohmann::json j = {{"format", "gonio-poses"}, {"version", 1}};
  j["frames"] = nlohmann::json::array();
  for (const auto& f : truth["frames"]) {
    if (j["frames"].size() >= max_poses) break;
    j["frames"].push_back({{"file", f["file"]}, {"cam_from_board", f["cam_from_board"]}});
  }
  j["skipped"] = nlohmann::json::array();
  WriteJsonAtomically(out, j);
}

inline std::vector<VignetteFrame> LoadVignetteFrames(const std::filesystem::path& session_dir,
                                                     const std::filesystem::path& poses_file) {
  const Session session = ReadSession(session_dir);
  const auto poses = ReadPoses(poses_file);
  std::vector<VignetteFrame> frames;
  for (size_t i = 0; i < session.frames.size() && i < poses.size(); ++i) {
    VignetteFrame f;
    f.file = session.frames[i].file;
    f.image = cv::imread(session.FramePath(i).string(), cv::IMREAD_UNCHANGED);
    f.exposure_s = session.frames[i].exposure_s;
    f.gain = session.frames[i].gain;
    f.cam_from_board = poses[i].second;
    frames.push_back(f);
  }
  return frames;
}

// Over the pixels where `mask` is non-zero (all when empty).
inline double RmsRelative(const cv::Mat& estimate, const cv::Mat& truth,
                          const cv::Mat& mask = cv::Mat()) {
  double sq = 0;
  size_t n = 0;
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      if (!mask.empty() && !mask.at<uint8_t>(y, x)) continue;
      sq += std::pow(estimate.at<float>(y, x) / truth.at<float>(y, x) - 1, 2);
      ++n;
    }
  }
  return std::sqrt(sq / std::max<size_t>(n, 1));
}

}  // namespace gonio::testing
