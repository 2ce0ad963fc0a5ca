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

}  // namespace

RectifiedRenderResult RenderRectifiedViews(const Scene& scene, int size, const fs::path& out_dir,
                                           int threads) {
  const auto start = std::chrono::steady_clock::now();
  scene.Check();
  if (!scene.texture.enabled()) throw InputError("--rectified: the scene has no texture");
  if (scene.light.type != "point") throw InputError("--rectified: the scene needs a point lamp");
  if (size < 16 || size > 4096) throw InputError("--rectified: size must be in [16, 4096] px");
  const TexturedShader shader(scene);
  const auto& region = scene.board.sample_region;
  const double side = std::min(region[2] - region[0], region[3] - region[1]);
  const Eigen::Vector2d centre(0.5 * (region[0] + region[2]), 0.5 * (region[1] + region[3]));
  const double z = -scene.board.sample_height;
  const auto poses = scene.CamFromBoardPoses();
  // The radiance of every view first: the exposure puts the brightest (99.9th percentile)
  // at 85% of the 8-bit range, as an auto-exposed phone photo would.
  std::vector<cv::Mat> radiance;
  std::vector<Eigen::Vector3d> cameras, lamps;
  std::vector<float> all;
  for (const Rigid3d& cam_from_board : poses) {
    const Rigid3d board_from_cam = cam_from_board.Inverse();
    const Eigen::Vector3d camera = board_from_cam.t;
    const Eigen::Vector3d lamp = scene.light.frame == "camera"
                                     ? board_from_cam * scene.light.position
                                     : scene.light.position;
    cv::Mat im(size, size, CV_64FC3);
    ParallelFor(size, threads, [&](size_t b, size_t e) {
      for (size_t r = b; r < e; ++r) {
        for (int c = 0; c < size; ++c) {
          const Eigen::Vector3d p(centre.x() + ((c + 0.5) / size - 0.5) * side,
                                  centre.y() + ((r + 0.5) / size - 0.5) * side, z);
          const Rgb L = shader.Point(p, camera, lamp, scene.light.intensity);
          for (int k = 0; k < 3; ++k) im.ptr<double>(static_cast<int>(r))[3 * c + k] = L[k];
        }
      }
    });
    for (int i = 0; i < size * size * 3; i += 7)
      all.push_back(static_cast<float>(im.ptr<double>()[i]));
    radiance.push_back(im);
    cameras.push_back(camera);
    lamps.push_back(lamp);
  }
  std::nth_element(all.begin(), all.begin() + all.size() * 999 / 1000, all.end());
  const double bright = std::max(1e-30, static_cast<double>(all[all.size() * 999 / 1000]));
  PhotometricSpec spec = scene.photometric;
  spec.bit_depth = 8;
  spec.response = "gamma";
  spec.gamma = 2.2;
  spec.black_level = 0;
  spec.vignetting = {0, 0, 0};
  spec.exposure_scale = 1.0;
  const double exposure = 0.85 / bright;
  const PhotometricChain chain(spec, scene.camera);
  EnsureDirectory(out_dir);
  std::string camera_lines, light_lines;
  for (size_t v = 0; v < radiance.size(); ++v) {
    cv::Mat image(size, size, CV_8UC3);
    for (int r = 0; r < size; ++r) {
      std::mt19937_64 rng(RowSeed(scene.seed, v, r));
      for (int c = 0; c < size; ++c) {
        for (int k = 0; k < 3; ++k) {
          const double L = radiance[v].ptr<double>(r)[3 * c + k];
          image.ptr<uint8_t>(r)[3 * c + (2 - k)] =
              static_cast<uint8_t>(chain.Value(L, exposure, c, r, rng));
        }
      }
    }
    const fs::path file = out_dir / fmt::format("{:02d}.png", v);
    WriteAtomically(file, [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), image); });
    camera_lines += PositionLine(cameras[v], centre);
    light_lines += PositionLine(lamps[v], centre);
  }
  WriteTextAtomically(out_dir / "camera_pos.txt", camera_lines);
  WriteTextAtomically(out_dir / "light_pos.txt", light_lines);
  WriteTextAtomically(out_dir / "image_size.txt", fmt::format("{:.6f}\n", 100 * side));
  const std::array<double, 4> square = {centre.x() - 0.5 * side, centre.y() - 0.5 * side,
                                        centre.x() + 0.5 * side, centre.y() + 0.5 * side};
  nlohmann::json truth = {
      {"format", "gonio-synth-truth"},
      {"version", 1},
      {"scene_type", "rectified"},
      {"material", Material(scene.material).ToJson()},
      {"rectified",
       {{"size", size},
        {"side_m", side},
        {"centre_in_board", {centre.x(), centre.y()}},
        {"decoding", "X = (value / 255)^2.2"},
        {"exposure", exposure},
        {"exposure_meaning",
         "X = exposure * radiance before noise; radiance = f_r * intensity * cos / d^2"},
        {"lamp_intensity", scene.light.intensity}}},
      {"photometric", chain.ToJson()},
      {"scene", SceneToJson(scene)}};
  truth["texture"] = WriteTextureTruth(scene, square, side / size, out_dir);
  WriteJsonAtomically(out_dir / "truth.json", truth);
  RectifiedRenderResult result;
  result.views = static_cast<int>(radiance.size());
  result.size = size;
  result.side_m = side;
  result.exposure = exposure;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace gonio::synth
