// MaterialGAN's rectified multi-view layout (docs/maps.md "Rectified captures"): NN.png views
// of the planar sample rectified to its square (8-bit, gamma 2.2 as that code decodes them),
// camera_pos.txt and light_pos.txt (one x,y,z line per view, cm), image_size.txt (the square's
// side, cm). The sample is the plane z = 0 centred at the origin, z towards the camera, pixel
// (row r, column c) of an N x N view at x = ((c + 0.5)/N - 0.5) s, y = -((r + 0.5)/N - 0.5) s.
// In gonio's board frame (z into the sample, y down) that is (x, -y, -z): texel (c, r) of the
// grid is pixel (c, r) of every view.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <regex>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/io.h"
#include "common/parse.h"
#include "estimation/maps/maps.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

constexpr double kGamma = 2.2;

std::vector<Eigen::Vector3d> ReadPositions(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot be read");
  std::vector<Eigen::Vector3d> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    std::vector<double> v;
    std::string word;
    while (fields >> word) {
      v.push_back(ParseNumber(word, fmt::format("{} line {}", path.string(), number)));
    }
    if (v.empty()) continue;
    if (v.size() != 3) {
      throw InputError(fmt::format("{} line {}: expected x,y,z", path.string(), number));
    }
    // cm in MaterialGAN's frame -> metres in the board frame.
    out.emplace_back(0.01 * v[0], -0.01 * v[1], -0.01 * v[2]);
  }
  return out;
}

// The view files NN.png in numeric order.
std::vector<fs::path> ViewFiles(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw InputError(dir.string() + ": not a folder");
  const std::regex pattern(R"(\d+\.png)");
  std::vector<std::pair<long, fs::path>> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (std::regex_match(name, pattern)) files.emplace_back(std::stol(name), e.path());
  }
  std::sort(files.begin(), files.end());
  std::vector<fs::path> out;
  for (const auto& [k, p] : files) out.push_back(p);
  if (out.empty()) throw InputError(dir.string() + ": no NN.png views");
  return out;
}

// One decoded view into its samples: X = (v / 255)^2.2 per channel (R, G, B); saturated (255)
// and black (0) values are left out. Noise bases: quantisation through the decoding,
// (dX/dv)^2 / 12, and the signal X for shot-like noise.
ViewSamples DecodeView(const fs::path& file, int n, int channels) {
  const cv::Mat im = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  if (im.empty()) throw InputError(file.string() + ": cannot be read as an image");
  if (im.depth() != CV_8U) throw InputError(file.string() + ": not an 8-bit image");
  if (im.rows != n || im.cols != n) {
    throw InputError(
        fmt::format("{}: {}x{}, the first view is {}x{}", file.string(), im.cols, im.rows, n, n));
  }
  const int C = im.channels() >= 3 ? 3 : 1;
  if (C != channels)
    throw InputError(file.string() + ": channel count differs from the first view's");
  ViewSamples s;
  const size_t texels = static_cast<size_t>(n) * n;
  s.radiance.assign(texels * C, 0.f);
  s.var_read.assign(texels * C, 0.f);
  s.var_shot.assign(texels * C, 0.f);
  s.valid.assign(texels, 0);
  for (int y = 0; y < n; ++y) {
    const uint8_t* row = im.ptr<uint8_t>(y);
    for (int x = 0; x < n; ++x) {
      const size_t t = static_cast<size_t>(y) * n + x;
      bool ok = true;
      for (int c = 0; c < C; ++c) {
        const int k = C == 3 ? 2 - c : 0;  // OpenCV's B, G, R
        const double v = row[x * im.channels() + k];
        ok &= v > 0 && v < 255;
        const double u = v / 255.0;
        const double X = std::pow(u, kGamma);
        const double slope = kGamma / 255.0 * std::pow(u, kGamma - 1);
        s.radiance[t * C + c] = static_cast<float>(X);
        s.var_read[t * C + c] = static_cast<float>(slope * slope / 12.0);
        s.var_shot[t * C + c] = static_cast<float>(X);
      }
      s.valid[t] = ok;
      s.count += ok;
    }
  }
  return s;
}

double ReadSide(const fs::path& path) {
  const std::string text = ReadTextFile(path);
  std::string word;
  std::istringstream(text) >> word;
  const double s = ParseNumber(word, path.string());
  if (!(s > 0 && s < 1e4)) throw InputError(path.string() + ": the side must be > 0 cm");
  return 0.01 * s;
}

}  // namespace

MapsResult MapsFromRectified(const fs::path& dir, const MapsOptions& o) {
  o.Check();
  const std::vector<fs::path> files = ViewFiles(dir);
  const std::vector<Eigen::Vector3d> cameras = ReadPositions(dir / "camera_pos.txt");
  const std::vector<Eigen::Vector3d> lamps = ReadPositions(dir / "light_pos.txt");
  if (cameras.size() != files.size() || lamps.size() != files.size()) {
    throw InputError(fmt::format("{}: {} views, {} camera and {} lamp positions", dir.string(),
                                 files.size(), cameras.size(), lamps.size()));
  }
  const double side = ReadSide(dir / "image_size.txt");
  const cv::Mat first = cv::imread(files[0].string(), cv::IMREAD_UNCHANGED);
  if (first.empty()) throw InputError(files[0].string() + ": cannot be read as an image");
  if (first.rows != first.cols) throw InputError(files[0].string() + ": views must be square");
  const int n = first.rows;
  TexelData data;
  data.channels = first.channels() >= 3 ? 3 : 1;
  data.grid.width = data.grid.height = n;
  data.grid.texel = side / n;
  data.grid.origin = Eigen::Vector2d::Constant((0.5 / n - 0.5) * side);
  data.grid.plane_z = 0;
  data.mask.assign(data.grid.size(), 1);
  data.reach_m = data.grid.texel;  // a rectified pixel mixes its neighbours (a resampled view)
  MapsLamp lamp;
  lamp.frame = MapsLamp::Frame::kPerView;
  lamp.intensity = 1;  // the flash power: in the albedo's scale (docs/maps.md)
  for (size_t v = 0; v < files.size(); ++v) {
    if (!(cameras[v].z() < 0) || !(lamps[v].z() < 0)) {
      throw InputError(fmt::format("{}: view {} has its camera or lamp below the sample (z <= 0)",
                                   dir.string(), v));
    }
    TexelView view;
    view.name = files[v].filename().string();
    view.camera_in_board = cameras[v];
    view.board_from_cam.t = cameras[v];
    data.views.push_back(view);
    data.samples.push_back(DecodeView(files[v], n, data.channels));
    lamp.per_view.push_back(lamps[v]);
  }
  MapsResult r = SolveMaps(std::move(data), lamp, o);
  r.input = dir.string();
  r.lamp_source = "light_pos.txt (per view); its power in the albedo's scale";
  return r;
}

}  // namespace gonio
