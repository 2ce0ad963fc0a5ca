#include "data_synth/board_renderer.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"
#include "data_synth/photometric.h"
#include "data_synth/shading.h"
#include "data_synth/tag_board.h"
#include "data_synth/textured_shading.h"

namespace fs = std::filesystem;

namespace gonio::synth {
namespace {

using json = nlohmann::json;

// Unit-z ray directions (x, y, 1) in the camera frame through the pixel-square corners
// (x - 0.5, y - 0.5), x in [0, W], y in [0, H]: one undistortion per corner, shared by all
// poses.
std::vector<Eigen::Vector3d> CornerRays(const CameraModel& camera, int threads) {
  const int w1 = camera.width + 1, h1 = camera.height + 1;
  std::vector<Eigen::Vector3d> rays(static_cast<size_t>(w1) * h1);
  ParallelFor(h1, threads, [&](size_t b, size_t e) {
    for (size_t y = b; y < e; ++y) {
      for (int x = 0; x < w1; ++x) {
        rays[y * w1 + x] = camera.Unproject(Eigen::Vector2d(x - 0.5, y - 0.5));
      }
    }
  });
  return rays;
}

struct PoseGeometry {
  Rigid3d cam_from_board;
  Eigen::Vector3d camera_in_board;
  Eigen::Vector3d lamp_in_board;     // point lamp
  Eigen::Vector3d to_lamp_in_board;  // distant lamp (unit)
};

// Whether the 2-D segment a-b meets the axis-aligned rectangle r = [xmin, ymin, xmax, ymax]
// (Liang-Barsky clipping).
bool SegmentMeetsRect(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                      const std::array<double, 4>& r) {
  double t0 = 0, t1 = 1;
  const Eigen::Vector2d d = b - a;
  const double p[4] = {-d.x(), d.x(), -d.y(), d.y()};
  const double q[4] = {a.x() - r[0], r[2] - a.x(), a.y() - r[1], r[3] - a.y()};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0) {
      if (q[k] < 0) return false;
      continue;
    }
    const double t = q[k] / p[k];
    if (p[k] < 0) {
      t0 = std::max(t0, t);
    } else {
      t1 = std::min(t1, t);
    }
    if (t0 > t1) return false;
  }
  return true;
}

bool InRect(const Eigen::Vector2d& p, const std::array<double, 4>& r) {
  return p.x() >= r[0] && p.x() < r[2] && p.y() >= r[1] && p.y() < r[3];
}

class BoardShader {
 public:
  BoardShader(const Scene& scene, const Material& material)
      : scene_(scene), material_(material), point_lamp_(scene.lamp.type == LampType::kPoint) {
    // rho_dh(theta_r) tabulated once: the ambient term of the sample (scene.h LampSpec).
    if (scene.lamp.ambient_irradiance > 0) {
      for (int k = 0; k <= kAlbedoSteps; ++k) {
        rho_dh_.push_back(material.DirectionalAlbedo(0.5 * kPi * k / kAlbedoSteps));
      }
    }
    if (scene.texture.enabled()) textured_.emplace(scene);
  }

  // Radiance (R, G, B; equal for grey surfaces) of surface s at board point p (z = 0, the
  // sample z = -sample_height) seen from the pose's camera; with the lamp off, the ambient
  // alone. A textured sample is shaded per point (textured_shading.h).
  Rgb Radiance(Surface s, const Eigen::Vector3d& p, const PoseGeometry& g, bool lamp_on) const {
    if (s == Surface::kSample && textured_) {
      if (!lamp_on) return {0, 0, 0};  // textured scenes have no ambient light (Scene::Check)
      return point_lamp_
                 ? textured_->Point(p, g.camera_in_board, g.lamp_in_board, scene_.lamp.intensity)
                 : textured_->Distant(p, g.camera_in_board, g.to_lamp_in_board,
                                      scene_.lamp.irradiance);
    }
    const double v = GreyRadiance(s, p, g, lamp_on);
    return {v, v, v};
  }

 private:
  double GreyRadiance(Surface s, const Eigen::Vector3d& p, const PoseGeometry& g,
                      bool lamp_on) const {
    if (s == Surface::kBackground) return 0.0;
    const Eigen::Vector3d n(0, 0, -1);  // outward normal of the board's printed side
    Eigen::Vector3d l;
    double e = 0;
    if (point_lamp_) {
      e = PointIrradiance(p, n, g.lamp_in_board, scene_.lamp.intensity, &l);
    } else {
      l = g.to_lamp_in_board;
      e = scene_.lamp.irradiance * std::max(0.0, n.dot(l));
    }
    if (!lamp_on || (s != Surface::kSample && ShadowedBySample(p, l))) e = 0;
    const double ambient = scene_.lamp.ambient_irradiance;
    switch (s) {
      case Surface::kPaper:
        return scene_.board.white_albedo * kInvPi * (e + ambient);
      case Surface::kInk:
        return scene_.board.black_albedo * kInvPi * (e + ambient);
      default: {
        const Eigen::Vector3d v = (g.camera_in_board - p).normalized();
        const double lamp = e > 0 ? material_.Brdf(LocalAngles(n, l, v)) * e : 0.0;
        return lamp +
               (ambient > 0 ? RhoDh(std::acos(std::min(1.0, n.dot(v)))) * ambient * kInvPi : 0.0);
      }
    }
  }

  static constexpr int kAlbedoSteps = 90;
  double RhoDh(double theta_r) const {
    const double x = std::clamp(theta_r / (0.5 * kPi), 0.0, 1.0) * kAlbedoSteps;
    const int k = std::min(static_cast<int>(x), kAlbedoSteps - 1);
    return rho_dh_[k] + (x - k) * (rho_dh_[k + 1] - rho_dh_[k]);
  }
  // A raised sample shades the board beside it: the part of the ray to the lamp below the
  // sample's top meets the sample's footprint.
  bool ShadowedBySample(const Eigen::Vector3d& p, const Eigen::Vector3d& to_lamp) const {
    const double h = scene_.board.sample_height;
    if (h <= 0 || !(to_lamp.z() < 0)) return false;
    const Eigen::Vector3d top = p + (h / -to_lamp.z()) * to_lamp;
    return SegmentMeetsRect(p.head<2>(), top.head<2>(), scene_.board.sample_region);
  }

  const Scene& scene_;
  const Material& material_;
  // The lamp's type resolved once (Radiance runs per sub-pixel sample).
  const bool point_lamp_;
  std::vector<double> rho_dh_;
  std::optional<TexturedShader> textured_;
};

// One pixel footprint: the board points of its four corners (z = 0) and, for a raised sample,
// the points of the same rays on the sample's top plane.
struct Footprint {
  const Eigen::Vector2d *a, *b, *c, *d;  // board plane
  const Eigen::Vector2d *ta = nullptr, *tb = nullptr, *tc = nullptr,
                        *td = nullptr;  // sample top plane (raised sample only)
  Eigen::Vector2d Board(double u, double v) const {
    return (1 - v) * ((1 - u) * *a + u * *b) + v * ((1 - u) * *c + u * *d);
  }
  Eigen::Vector2d Top(double u, double v) const {
    return (1 - v) * ((1 - u) * *ta + u * *tb) + v * ((1 - u) * *tc + u * *td);
  }
};

// The box-filtered radiance of a footprint that crosses an edge: S^2 points of a
// multi-jittered pattern (one sample per cell of an S x S grid and per row and column of the
// S^2 x S^2 grid, so an edge along either image axis is resolved to 1/S^2 of a pixel), each
// surface's radiance evaluated once at the footprint centre (the sample's on its top plane).
// A point whose ray passes the raised sample's side is black.
Rgb SupersampledRadiance(const Scene& scene, const TagBoard& board, const BoardShader& shader,
                         const PoseGeometry& g, const Footprint& fp, bool raised, bool lamp_on) {
  const int ss = scene.supersampling;
  const double h = scene.board.sample_height;
  const auto& rect = scene.board.sample_region;
  int counts[4] = {0, 0, 0, 0};
  for (int j = 0; j < ss; ++j) {
    for (int i = 0; i < ss; ++i) {
      const double u = (i * ss + j + 0.5) / (ss * ss), v = (j * ss + i + 0.5) / (ss * ss);
      const Eigen::Vector2d p = fp.Board(u, v);
      if (!raised) {
        ++counts[static_cast<int>(board.At(p.x(), p.y()))];
        continue;
      }
      const Eigen::Vector2d t = fp.Top(u, v);
      if (InRect(t, rect)) {
        ++counts[static_cast<int>(Surface::kSample)];
      } else if (!SegmentMeetsRect(p, t, rect)) {
        ++counts[static_cast<int>(board.At(p.x(), p.y()))];
      }  // else: the sample's side
    }
  }
  const Eigen::Vector2d centre = fp.Board(0.5, 0.5);
  Rgb sum = {0, 0, 0};
  for (int k = 1; k < 4; ++k) {
    if (!counts[k]) continue;
    const bool top = raised && k == static_cast<int>(Surface::kSample);
    const Eigen::Vector2d q = top ? fp.Top(0.5, 0.5) : centre;
    const Rgb r = shader.Radiance(static_cast<Surface>(k),
                                  Eigen::Vector3d(q.x(), q.y(), top ? -h : 0.0), g, lamp_on);
    for (int c = 0; c < 3; ++c) sum[c] += counts[k] * r[c];
  }
  for (double& v : sum) v /= ss * ss;
  return sum;
}

// Radiance of one footprint: one surface seen whole (evaluated at the centre), else
// supersampled. Counts supersampled footprints.
Rgb FootprintRadiance(const Scene& scene, const TagBoard& board, const BoardShader& shader,
                      const PoseGeometry& g, const Footprint& fp, bool lamp_on,
                      size_t* supersampled) {
  const double h = scene.board.sample_height;
  const auto& rect = scene.board.sample_region;
  const Eigen::Vector2d lo = fp.a->cwiseMin(*fp.b).cwiseMin(*fp.c).cwiseMin(*fp.d);
  const Eigen::Vector2d hi = fp.a->cwiseMax(*fp.b).cwiseMax(*fp.c).cwiseMax(*fp.d);
  const Eigen::Vector2d centre = fp.Board(0.5, 0.5);
  bool raised = false;
  if (h > 0) {
    const Eigen::Vector2d tlo = fp.ta->cwiseMin(*fp.tb).cwiseMin(*fp.tc).cwiseMin(*fp.td);
    const Eigen::Vector2d thi = fp.ta->cwiseMax(*fp.tb).cwiseMax(*fp.tc).cwiseMax(*fp.td);
    if (InRect(tlo, rect) && InRect(thi, rect)) {  // on the top
      const Eigen::Vector2d t = fp.Top(0.5, 0.5);
      return shader.Radiance(Surface::kSample, Eigen::Vector3d(t.x(), t.y(), -h), g, lamp_on);
    }
    // Footprint and its rays' way down from the top clear of the sample: the board alone.
    const Eigen::Vector2d ulo = lo.cwiseMin(tlo), uhi = hi.cwiseMax(thi);
    raised = !(uhi.x() < rect[0] || ulo.x() >= rect[2] || uhi.y() < rect[1] || ulo.y() >= rect[3]);
  }
  Surface s;
  if (!raised && board.Uniform(lo.x(), lo.y(), hi.x(), hi.y(), &s)) {
    return shader.Radiance(s, Eigen::Vector3d(centre.x(), centre.y(), 0.0), g, lamp_on);
  }
  ++*supersampled;
  return SupersampledRadiance(scene, board, shader, g, fp, raised, lamp_on);
}

// Where the rays through the pixel corners meet the plane z = plane_z; hit false where the ray
// misses it (towards the horizon).
void TraceCorners(const std::vector<Eigen::Vector3d>& rays, const PoseGeometry& g, double plane_z,
                  int threads, std::vector<Eigen::Vector2d>* corner, std::vector<char>* hit) {
  const Eigen::Matrix3d board_from_cam = g.cam_from_board.R.transpose();
  const Eigen::Vector3d c = g.camera_in_board;
  corner->resize(rays.size());
  hit->resize(rays.size());
  ParallelFor(rays.size(), threads, [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      const Eigen::Vector3d d = board_from_cam * rays[k];
      const bool ok = d.z() > 1e-12 && plane_z - c.z() > 0;
      (*hit)[k] = ok;
      const double t = ok ? (plane_z - c.z()) / d.z() : 0.0;
      (*corner)[k] = (c + t * d).head<2>();
    }
  });
}

// Radiance image of one pose (the lamp on or off), CV_64FC(scene.Channels()) in R, G, B order;
// counts supersampled footprints.
cv::Mat RenderRadiance(const Scene& scene, const TagBoard& board, const BoardShader& shader,
                       const std::vector<Eigen::Vector3d>& rays, const PoseGeometry& g,
                       bool lamp_on, int threads, size_t* supersampled) {
  const int w = scene.camera.width, h = scene.camera.height, w1 = w + 1;
  std::vector<Eigen::Vector2d> corner, top;
  std::vector<char> hit, top_hit;
  TraceCorners(rays, g, 0.0, threads, &corner, &hit);
  const bool raised = scene.board.sample_height > 0;
  if (raised) TraceCorners(rays, g, -scene.board.sample_height, threads, &top, &top_hit);
  const int channels = scene.Channels();
  cv::Mat radiance(h, w, CV_64FC(channels));
  std::atomic<size_t> count{0};
  ParallelFor(h, threads, [&](size_t b, size_t e) {
    size_t local = 0;
    for (size_t y = b; y < e; ++y) {
      double* row = radiance.ptr<double>(static_cast<int>(y));
      for (int x = 0; x < w; ++x) {
        const size_t i00 = y * w1 + x, i10 = i00 + 1, i01 = i00 + w1, i11 = i01 + 1;
        double* out = row + x * channels;
        if (!hit[i00] || !hit[i10] || !hit[i01] || !hit[i11]) {
          // The footprint reaches the board's horizon: far off the board.
          for (int c = 0; c < channels; ++c) out[c] = 0.0;
          continue;
        }
        Footprint fp{&corner[i00], &corner[i10], &corner[i01], &corner[i11]};
        if (raised) fp = {fp.a, fp.b, fp.c, fp.d, &top[i00], &top[i10], &top[i01], &top[i11]};
        const Rgb r = FootprintRadiance(scene, board, shader, g, fp, lamp_on, &local);
        for (int c = 0; c < channels; ++c) out[c] = r[c];
      }
    }
    count += local;
  });
  *supersampled += count;
  return radiance;
}

json TagCornersJson(const TagBoard& board, const CameraModel& camera,
                    const Rigid3d& cam_from_board) {
  json out = json::array();
  for (const auto& tag : board.Corners()) {
    json corners = json::array();
    bool visible = true;
    for (const auto& p : tag.corners) {
      const Eigen::Vector3d q = cam_from_board * p;
      if (q.z() <= 0) {
        visible = false;
        break;
      }
      const Eigen::Vector2d px = camera.Project(q);
      visible &=
          px.x() >= 0 && px.y() >= 0 && px.x() <= camera.width - 1 && px.y() <= camera.height - 1;
      corners.push_back({px.x(), px.y()});
    }
    if (visible) out.push_back({{"id", tag.id}, {"corners_px", corners}});
  }
  return out;
}

json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// The geometry of one pose: where the camera and the lamp are in the board frame.
PoseGeometry PoseGeometryOf(const Scene& scene, const Rigid3d& cam_from_board) {
  PoseGeometry g;
  g.cam_from_board = cam_from_board;
  const Rigid3d board_from_cam = cam_from_board.Inverse();
  g.camera_in_board = board_from_cam.t;
  const bool lamp_in_cam = scene.lamp.frame == LampFrame::kCamera;
  g.lamp_in_board = lamp_in_cam ? board_from_cam * scene.lamp.position : scene.lamp.position;
  g.to_lamp_in_board =
      (lamp_in_cam ? board_from_cam.R * scene.lamp.direction : scene.lamp.direction).normalized();
  return g;
}

// Pixel values of frame `frame` from its radiance image (R, G, B order); a colour frame is
// stored in OpenCV's B, G, R order so the file reads as RGB. Counts pixels with a saturated
// channel.
cv::Mat ExposeFrame(const Scene& scene, const PhotometricChain& chain, const cv::Mat& radiance,
                    double exposure_s, int frame, int threads, size_t* saturated_pixels) {
  const int w = scene.camera.width, h = scene.camera.height;
  const int channels = radiance.channels();
  const bool eight_bit = scene.photometric.bit_depth == 8;
  cv::Mat image(h, w, CV_MAKETYPE(eight_bit ? CV_8U : CV_16U, channels));
  std::atomic<size_t> saturated{0};
  ParallelFor(h, threads, [&](size_t b, size_t e) {
    size_t local = 0;
    for (size_t y = b; y < e; ++y) {
      std::mt19937_64 rng(RowSeed(scene.seed, frame, y));
      const double* in = radiance.ptr<double>(static_cast<int>(y));
      for (int x = 0; x < w; ++x) {
        bool saturated_pixel = false;
        for (int c = 0; c < channels; ++c) {
          const uint16_t v =
              chain.Value(in[x * channels + c], exposure_s, x, static_cast<double>(y), rng);
          saturated_pixel |= v >= chain.max_value();
          const int k = x * channels + (channels - 1 - c);  // R, G, B -> B, G, R
          if (eight_bit) {
            image.ptr<uint8_t>(static_cast<int>(y))[k] = static_cast<uint8_t>(v);
          } else {
            image.ptr<uint16_t>(static_cast<int>(y))[k] = v;
          }
        }
        local += saturated_pixel;
      }
    }
    saturated += local;
  });
  *saturated_pixels = saturated;
  return image;
}

// truth.json "lamp": the lamp as the scene gives it, in its frame.
json LampTruthJson(const LampSpec& lamp) {
  json out = {{"type", ToString(lamp.type)}, {"frame", ToString(lamp.frame)}};
  const bool in_board = lamp.frame == LampFrame::kBoard;
  if (lamp.type == LampType::kPoint) {
    out[in_board ? "position_in_board" : "position_in_camera"] = Vec(lamp.position);
    out["intensity"] = lamp.intensity;
    out["falloff"] = "inverse-square: E = intensity * cos(theta_i) / d^2";
  } else {
    out[in_board ? "direction_in_board" : "direction_in_camera"] = Vec(lamp.direction.normalized());
    out["irradiance"] = lamp.irradiance;
  }
  return out;
}

// board.json, camera.cameramodel, session.json and truth.json of a rendered session.
void WriteSessionFiles(const Scene& scene, const TagBoard& board, const Material& material,
                       const PhotometricChain& chain, const json& session_frames,
                       const json& dark_frames, const json& truth_frames, const fs::path& out_dir) {
  WriteJsonAtomically(out_dir / "board.json", board.BoardJson());
  scene.camera.Write(out_dir / "camera.cameramodel",
                     "gonio synth: the camera that rendered this session");
  json session = {{"format", "gonio-session"},
                  {"version", 1},
                  {"camera_id", "synthetic"},
                  {"board", "board.json"},
                  {"bit_depth", scene.photometric.bit_depth},
                  {"frames", session_frames}};
  if (!dark_frames.empty()) session["dark_frames"] = dark_frames;
  WriteJsonAtomically(out_dir / "session.json", session);
  json photometric = chain.ToJson();
  photometric["channels"] = scene.Channels();
  json truth = {{"format", "gonio-synth-truth"},
                {"version", 1},
                {"scene_type", ToString(scene.type)},
                {"material", material.ToJson()},
                {"lamp", LampTruthJson(scene.lamp)},
                {"white_albedo", scene.board.white_albedo},
                {"ambient_irradiance", scene.lamp.ambient_irradiance},
                {"black_albedo", scene.board.black_albedo},
                {"board",
                 {{"file", "board.json"},
                  {"sample_height", scene.board.sample_height},
                  {"sample_region", scene.board.sample_region},
                  {"white_region", scene.board.white_region}}},
                {"camera",
                 {{"file", "camera.cameramodel"},
                  {"lens_model", LensModelName(scene.camera.lens_model)},
                  {"intrinsics", scene.camera.intrinsics},
                  {"width", scene.camera.width},
                  {"height", scene.camera.height}}},
                {"frames", truth_frames},
                {"photometric", photometric},
                {"render",
                 {{"supersampling", scene.supersampling},
                  {"seed", scene.seed},
                  {"pixel_filter",
                   "box over the pixel square; radiance per surface at the "
                   "footprint centre"}}},
                {"scene", SceneToJson(scene)}};
  if (scene.texture.enabled()) {
    truth["texture"] =
        WriteTextureTruth(scene, scene.board.sample_region, scene.texture.truth_texel, out_dir);
  }
  WriteJsonAtomically(out_dir / "truth.json", truth);
}

// Frames with the lens capped: no light reaches the sensor, so the chain gives the black level
// with read noise and quantisation. Their own noise: frame numbers beyond the lit and lamp-off
// frames' seed the generator.
json WriteDarkFrames(const Scene& scene, const PhotometricChain& chain, const fs::path& out_dir,
                     int threads) {
  json names = json::array();
  const cv::Mat no_lamp =
      cv::Mat::zeros(scene.camera.height, scene.camera.width, CV_64FC(scene.Channels()));
  for (int k = 0; k < scene.views.dark_frames; ++k) {
    size_t saturated = 0;
    const cv::Mat dark = ExposeFrame(scene, chain, no_lamp, scene.views.exposures_s.front(),
                                     (2 << 20) + k, threads, &saturated);
    char name[32];
    std::snprintf(name, sizeof(name), "dark_%04d.png", k);
    WriteAtomically(out_dir / name,
                    [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), dark); });
    names.push_back(name);
  }
  return names;
}

}  // namespace

std::string BoardRenderResult::Report() const {
  double worst = 0;
  for (double f : saturated_fraction) worst = std::max(worst, f);
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "%d frames (%d poses) in %.2f s, %zu footprints supersampled, max saturated "
                "fraction %.4f",
                frames, poses, seconds, supersampled_pixels, worst);
  return buf;
}

BoardRenderResult RenderBoardSession(const Scene& scene, const fs::path& out_dir, int threads) {
  const auto start = std::chrono::steady_clock::now();
  scene.Check();
  const Material material(scene.material);
  const TagBoard board(scene.board);
  const PhotometricChain chain(scene.photometric, scene.camera);
  const BoardShader shader(scene, material);
  const auto poses = scene.CamFromBoardPoses();
  const auto& exposures = scene.views.exposures_s;
  EnsureDirectory(out_dir);

  const std::vector<Eigen::Vector3d> rays = CornerRays(scene.camera, threads);
  BoardRenderResult result;
  result.poses = static_cast<int>(poses.size());
  json session_frames = json::array(), truth_frames = json::array();
  const double pixels = static_cast<double>(scene.camera.width) * scene.camera.height;
  Progress progress("synth: rendering frames", poses.size() * exposures.size());
  int frame = 0;
  for (size_t pose_index = 0; pose_index < poses.size(); ++pose_index) {
    const PoseGeometry g = PoseGeometryOf(scene, poses[pose_index]);
    const cv::Mat radiance =
        RenderRadiance(scene, board, shader, rays, g, true, threads, &result.supersampled_pixels);
    cv::Mat lamp_off_radiance;
    if (scene.lamp.lamp_off_frames) {
      size_t unused = 0;
      lamp_off_radiance = RenderRadiance(scene, board, shader, rays, g, false, threads, &unused);
    }
    const json corners = TagCornersJson(board, scene.camera, g.cam_from_board);
    for (double exposure_s : exposures) {
      size_t saturated = 0;
      const cv::Mat image =
          ExposeFrame(scene, chain, radiance, exposure_s, frame, threads, &saturated);
      char name[32];
      std::snprintf(name, sizeof(name), "frame_%04d.png", frame);
      WriteAtomically(out_dir / name,
                      [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), image); });
      result.saturated_fraction.push_back(static_cast<double>(saturated) / pixels);
      json session_frame = {{"file", name},
                            {"exposure_s", exposure_s},
                            {"gain", 1.0},
                            {"timestamp", 0.1 * frame},
                            {"bracket", static_cast<int>(pose_index)}};
      if (scene.lamp.lamp_off_frames) {
        // Its own noise: frame numbers far beyond the lit frames' seed the generator.
        size_t off_saturated = 0;
        const cv::Mat off = ExposeFrame(scene, chain, lamp_off_radiance, exposure_s,
                                        (1 << 20) + frame, threads, &off_saturated);
        char off_name[40];
        std::snprintf(off_name, sizeof(off_name), "frame_%04d_lamp_off.png", frame);
        WriteAtomically(out_dir / off_name,
                        [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), off); });
        session_frame["lamp_off"] = off_name;
      }
      session_frames.push_back(session_frame);
      json tf = {{"file", name},
                 {"cam_from_board", ToJson(g.cam_from_board)},
                 {"exposure_s", exposure_s},
                 {"camera_in_board", Vec(g.camera_in_board)},
                 {"tag_corners", corners}};
      if (scene.lamp.type == LampType::kPoint) tf["lamp_in_board"] = Vec(g.lamp_in_board);
      truth_frames.push_back(tf);
      ++frame;
      progress.Step();
    }
  }
  progress.Done();
  result.frames = frame;
  const json dark_frames = WriteDarkFrames(scene, chain, out_dir, threads);
  WriteSessionFiles(scene, board, material, chain, session_frames, dark_frames, truth_frames,
                    out_dir);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace gonio::synth
