#include "data_synth/rectified_views.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/io.h"
#include "common/parallel.h"
#include "data_synth/photometric.h"
#include "data_synth/shading.h"
#include "data_synth/textured_shading.h"

namespace fs = std::filesystem;

namespace gonio::synth {
namespace {

// A board-frame point in MaterialGAN's frame, cm: centred on the square, y and z flipped.
std::string PositionLine(const Eigen::Vector3d& p, const Eigen::Vector2d& centre) {
  return fmt::format("{:.6f},{:.6f},{:.6f}\n", 100 * (p.x() - centre.x()),
                     -100 * (p.y() - centre.y()), -100 * p.z());
}

// The square of the sample region the views show, in the board frame.
struct RectifiedSquare {
  double side;             // metres
  Eigen::Vector2d centre;  // in the board's plane
  double z;                // the sample's surface
};

// One view's radiance (CV_64FC3, RGB) and where its camera and lamp are, in the board frame.
struct RadianceView {
  cv::Mat radiance;
  Eigen::Vector3d camera, lamp;
};

RadianceView RenderRadiance(const Scene& scene, const TexturedShader& shader,
                            const RectifiedSquare& sq, int size, int threads,
                            const Rigid3d& cam_from_board) {
  const Rigid3d board_from_cam = cam_from_board.Inverse();
  RadianceView v;
  v.camera = board_from_cam.t;
  v.lamp = scene.lamp.frame == LampFrame::kCamera ? board_from_cam * scene.lamp.position
                                                  : scene.lamp.position;
  cv::Mat im(size, size, CV_64FC3);
  ParallelFor(size, threads, [&](size_t b, size_t e) {
    for (size_t r = b; r < e; ++r) {
      for (int c = 0; c < size; ++c) {
        const Eigen::Vector3d p(sq.centre.x() + ((c + 0.5) / size - 0.5) * sq.side,
                                sq.centre.y() + ((r + 0.5) / size - 0.5) * sq.side, sq.z);
        const Rgb L = shader.Point(p, v.camera, v.lamp, scene.lamp.intensity);
        for (int k = 0; k < 3; ++k) im.ptr<double>(static_cast<int>(r))[3 * c + k] = L[k];
      }
    }
  });
  v.radiance = im;
  return v;
}

// The exposure that puts the brightest radiance (99.9th percentile of every 7th value) at 85%
// of the 8-bit range, as an auto-exposed phone photo would.
double AutoExposure(const std::vector<RadianceView>& views, int size) {
  std::vector<float> all;
  for (const RadianceView& v : views) {
    for (int i = 0; i < size * size * 3; i += 7) {
      all.push_back(static_cast<float>(v.radiance.ptr<double>()[i]));
    }
  }
  std::nth_element(all.begin(), all.begin() + all.size() * 999 / 1000, all.end());
  const double bright = std::max(1e-30, static_cast<double>(all[all.size() * 999 / 1000]));
  return 0.85 / bright;
}

// The scene's photometric chain as a phone's 8-bit sRGB-like encoding: gamma 2.2, black 0, no
// vignetting.
PhotometricSpec PhoneEncoding(const Scene& scene) {
  PhotometricSpec spec = scene.photometric;
  spec.bit_depth = 8;
  spec.response = ResponseCurve::kGamma;
  spec.gamma = 2.2;
  spec.black_level = 0;
  spec.vignetting = {0, 0, 0};
  spec.exposure_scale = 1.0;
  return spec;
}

// View v's radiance through the chain, with its noise (seeded per row), as 8-bit BGR.
cv::Mat EncodeView(const cv::Mat& radiance, const PhotometricChain& chain, double exposure,
                   uint64_t seed, size_t v) {
  const int size = radiance.rows;
  cv::Mat image(size, size, CV_8UC3);
  for (int r = 0; r < size; ++r) {
    std::mt19937_64 rng(RowSeed(seed, v, r));
    for (int c = 0; c < size; ++c) {
      for (int k = 0; k < 3; ++k) {
        const double L = radiance.ptr<double>(r)[3 * c + k];
        image.ptr<uint8_t>(r)[3 * c + (2 - k)] =
            static_cast<uint8_t>(chain.Value(L, exposure, c, r, rng));
      }
    }
  }
  return image;
}

nlohmann::json RectifiedTruth(const Scene& scene, const RectifiedSquare& sq, int size,
                              double exposure, const PhotometricChain& chain) {
  return {{"format", "gonio-synth-truth"},
          {"version", 1},
          {"scene_type", "rectified"},
          {"material", Material(scene.material).ToJson()},
          {"rectified",
           {{"size", size},
            {"side_m", sq.side},
            {"centre_in_board", {sq.centre.x(), sq.centre.y()}},
            {"decoding", "X = (value / 255)^2.2"},
            {"exposure", exposure},
            {"exposure_meaning",
             "X = exposure * radiance before noise; radiance = f_r * intensity * cos / d^2"},
            {"lamp_intensity", scene.lamp.intensity}}},
          {"photometric", chain.ToJson()},
          {"scene", SceneToJson(scene)}};
}

}  // namespace

RectifiedRenderResult RenderRectifiedViews(const Scene& scene, int size, const fs::path& out_dir,
                                           int threads) {
  const auto start = std::chrono::steady_clock::now();
  scene.Check();
  if (!scene.texture.enabled()) throw InputError("--rectified: the scene has no texture");
  if (scene.lamp.type != LampType::kPoint) {
    throw InputError("--rectified: the scene needs a point lamp");
  }
  if (size < 16 || size > 4096) throw InputError("--rectified: size must be in [16, 4096] px");
  const TexturedShader shader(scene);
  const auto& region = scene.board.sample_region;
  const RectifiedSquare sq{
      std::min(region[2] - region[0], region[3] - region[1]),
      Eigen::Vector2d(0.5 * (region[0] + region[2]), 0.5 * (region[1] + region[3])),
      -scene.board.sample_height};
  // The radiance of every view first: the exposure depends on all of them.
  std::vector<RadianceView> views;
  for (const Rigid3d& cam_from_board : scene.CamFromBoardPoses()) {
    views.push_back(RenderRadiance(scene, shader, sq, size, threads, cam_from_board));
  }
  const double exposure = AutoExposure(views, size);
  const PhotometricChain chain(PhoneEncoding(scene), scene.camera);
  EnsureDirectory(out_dir);
  std::string camera_lines, lamp_lines;
  for (size_t v = 0; v < views.size(); ++v) {
    const cv::Mat image = EncodeView(views[v].radiance, chain, exposure, scene.seed, v);
    const fs::path file = out_dir / fmt::format("{:02d}.png", v);
    WriteAtomically(file, [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), image); });
    camera_lines += PositionLine(views[v].camera, sq.centre);
    lamp_lines += PositionLine(views[v].lamp, sq.centre);
  }
  WriteTextAtomically(out_dir / "camera_pos.txt", camera_lines);
  WriteTextAtomically(out_dir / "light_pos.txt", lamp_lines);
  WriteTextAtomically(out_dir / "image_size.txt", fmt::format("{:.6f}\n", 100 * sq.side));
  const std::array<double, 4> square = {
      sq.centre.x() - 0.5 * sq.side, sq.centre.y() - 0.5 * sq.side, sq.centre.x() + 0.5 * sq.side,
      sq.centre.y() + 0.5 * sq.side};
  nlohmann::json truth = RectifiedTruth(scene, sq, size, exposure, chain);
  truth["texture"] = WriteTextureTruth(scene, square, sq.side / size, out_dir);
  WriteJsonAtomically(out_dir / "truth.json", truth);
  RectifiedRenderResult result;
  result.views = static_cast<int>(views.size());
  result.size = size;
  result.side_m = sq.side;
  result.exposure = exposure;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace gonio::synth
