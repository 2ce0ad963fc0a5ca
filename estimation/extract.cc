#include "estimation/extract.h"

#include <atomic>
#include <cmath>
#include <mutex>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "common/parallel.h"
#include "common/session.h"

namespace gonio {
namespace {

// Signed distance of p from a convex-or-not polygon's boundary: positive inside.
double InsideDistance(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  double dmin = INFINITY;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
    const Eigen::Vector2d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
    dmin = std::min(dmin, (a + t * ab - p).norm());
  }
  return inside ? dmin : -dmin;
}

struct Counters {
  std::atomic<size_t> saturated{0}, dark{0}, tag{0}, kept{0};
};

}  // namespace

void ExtractOptions::Check() const {
  if (patch < 1 || patch > 64) throw InputError("--patch must be in [1, 64]");
  if (!(edge_margin_px >= 0)) throw InputError("edge margin must be >= 0");
}

ObservationSet ExtractObservations(const std::filesystem::path& session_dir,
                                   const CameraModel& camera, const Board& board,
                                   const std::map<std::string, Rigid3d>& poses,
                                   const PhotometricCalibration& photometric,
                                   const ExtractOptions& options) {
  options.Check();
  if (board.sample_region().size() < 3) {
    throw InputError("board file has no sample_region: nothing to extract");
  }
  const Session session = ReadSession(session_dir);
  ObservationSet set;
  set.channels = photometric.response.channels;
  Counters count;
  size_t no_pose = 0;
  // Tag squares grown by one module of the tag's white border: those pixels are never sample.
  std::vector<std::vector<Eigen::Vector2d>> tags;
  if (!board.is_chessboard()) {
    const double grow = board.tag_size() / 8.0;
    for (size_t k = 0; k < board.ids().size(); ++k) {
      if (board.ids()[k] < 0) continue;
      const Eigen::Vector3d& tl = board.Points()[Board::TagPointIndex(static_cast<int>(k), 3)];
      const double s = board.tag_size();
      tags.push_back({{tl.x() - grow, tl.y() - grow},
                      {tl.x() + s + grow, tl.y() - grow},
                      {tl.x() + s + grow, tl.y() + s + grow},
                      {tl.x() - grow, tl.y() + s + grow}});
    }
  }
  std::mutex mutex;
  Progress progress("extract", session.frames.size());
  for (size_t f = 0; f < session.frames.size(); ++f) {
    const auto& frame = session.frames[f];
    set.frame_files.push_back(frame.file);
    const auto pose_it = poses.find(frame.file);
    if (pose_it == poses.end()) {
      ++no_pose;
      progress.Step();
      continue;
    }
    const Rigid3d& cam_from_board = pose_it->second;
    const Rigid3d board_from_cam = cam_from_board.Inverse();
    const Eigen::AngleAxisd aa(board_from_cam.R);
    const Eigen::Vector3d aa_vec = aa.angle() * aa.axis();
    const cv::Mat raw = cv::imread(session.FramePath(f).string(), cv::IMREAD_UNCHANGED);
    if (raw.empty())
      throw InputError(session.FramePath(f).string() + ": cannot be read as an image");
    if (raw.cols != camera.width || raw.rows != camera.height) {
      throw InputError(session.FramePath(f).string() +
                       ": image size differs from the camera model's");
    }
    cv::Mat radiance, variance, valid;
    photometric.ToRadiance(raw, frame.exposure_s, frame.gain, &radiance, &variance, &valid);
    const int C = set.channels;
    const double footprint = board_from_cam.t.norm() / camera.intrinsics[0];
    const double margin = options.edge_margin_px * footprint * options.patch;
    // Regions projected into the image bound the pixel loop.
    double umin = camera.width, umax = 0, vmin = camera.height, vmax = 0;
    std::vector<std::pair<const std::vector<Eigen::Vector2d>*, bool>> regions = {
        {&board.sample_region(), false}};
    if (options.white_reference && board.white_region().size() >= 3) {
      regions.push_back({&board.white_region(), true});
    }
    for (const auto& [poly, white] : regions) {
      for (const auto& q : *poly) {
        const Eigen::Vector3d p_in_cam = cam_from_board * Eigen::Vector3d(q.x(), q.y(), 0.0);
        if (p_in_cam.z() <= 0) continue;
        const Eigen::Vector2d px = camera.Project(p_in_cam);
        umin = std::min(umin, px.x());
        umax = std::max(umax, px.x());
        vmin = std::min(vmin, px.y());
        vmax = std::max(vmax, px.y());
      }
    }
    const int P = options.patch;
    const int u0 = std::max(0, static_cast<int>(umin) - 2),
              u1 = std::min(camera.width - P, static_cast<int>(umax) + 2);
    const int v0 = std::max(0, static_cast<int>(vmin) - 2),
              v1 = std::min(camera.height - P, static_cast<int>(vmax) + 2);
    const int rows = v1 >= v0 ? (v1 - v0) / P + 1 : 0;
    ParallelFor(rows, options.threads, [&](size_t rb, size_t re) {
      std::vector<Observation> local;
      for (size_t r = rb; r < re; ++r) {
        const int v = v0 + static_cast<int>(r) * P;
        for (int u = u0; u <= u1; u += P) {
          Eigen::Vector3d sum_p = Eigen::Vector3d::Zero();
          std::vector<double> sum(C, 0.0), sum_sq(C, 0.0), sum_var(C, 0.0);
          int n = 0, region_kind = -1;
          bool reject = false;
          for (int dv = 0; dv < P && !reject; ++dv) {
            for (int du = 0; du < P && !reject; ++du) {
              const Eigen::Vector3d ray_in_cam = camera.Unproject(Eigen::Vector2d(u + du, v + dv));
              const Eigen::Vector3d dir = board_from_cam.R * ray_in_cam;
              if (std::abs(dir.z()) < 1e-12) {
                reject = true;
                break;
              }
              const double s = -board_from_cam.t.z() / dir.z();
              if (s <= 0) {
                reject = true;
                break;
              }
              const Eigen::Vector3d p = board_from_cam.t + s * dir;
              const Eigen::Vector2d q(p.x(), p.y());
              int kind = -1;
              for (size_t k = 0; k < regions.size(); ++k) {
                if (InsideDistance(*regions[k].first, q) > margin) kind = static_cast<int>(k);
              }
              if (kind < 0 || (region_kind >= 0 && kind != region_kind)) {
                reject = true;
                break;
              }
              region_kind = kind;
              for (const auto& t : tags) {
                if (InsideDistance(t, q) > -margin) {
                  ++count.tag;
                  reject = true;
                  break;
                }
              }
              if (reject) break;
              if (!valid.at<uint8_t>(v + dv, u + du)) {
                const float* L = radiance.ptr<float>(v + dv) + (u + du) * C;
                (L[0] > 0 ? count.saturated : count.dark)++;
                reject = true;
                break;
              }
              const float* L = radiance.ptr<float>(v + dv) + (u + du) * C;
              const float* V = variance.ptr<float>(v + dv) + (u + du) * C;
              for (int c = 0; c < C; ++c) {
                sum[c] += L[c];
                sum_sq[c] += static_cast<double>(L[c]) * L[c];
                sum_var[c] += V[c];
              }
              sum_p += p;
              ++n;
            }
          }
          if (reject || n == 0) continue;
          Observation o;
          o.frame = static_cast<int>(f);
          o.px = u + 0.5 * (P - 1);
          o.py = v + 0.5 * (P - 1);
          o.p_in_board = sum_p / n;
          o.p_in_board.z() = 0.0;
          o.camera_in_board = board_from_cam.t;
          o.board_from_cam_aa = aa_vec;
          o.white = regions[region_kind].second;
          o.num_pixels = n;
          for (int c = 0; c < C; ++c) {
            const double mean = sum[c] / n;
            o.radiance.push_back(mean);
            // Variance of the patch mean: the larger of the propagated pixel noise and the
            // patch's own scatter (texture) divided by n.
            const double scatter =
                n > 1 ? std::max(0.0, sum_sq[c] / n - mean * mean) * n / (n - 1) : 0.0;
            o.variance.push_back(std::max(sum_var[c] / n, scatter) / n);
          }
          local.push_back(std::move(o));
        }
      }
      std::lock_guard<std::mutex> lock(mutex);
      count.kept += local.size();
      set.observations.insert(set.observations.end(), local.begin(), local.end());
    });
    progress.Step();
  }
  progress.Done();
  // Threads append in any order: sort so output is reproducible.
  std::sort(set.observations.begin(), set.observations.end(),
            [](const Observation& a, const Observation& b) {
              return std::tie(a.frame, a.py, a.px) < std::tie(b.frame, b.py, b.px);
            });
  set.excluded = {{"saturated", count.saturated.load()},
                  {"dark", count.dark.load()},
                  {"tag", count.tag.load()},
                  {"frames_without_pose", no_pose}};
  if (no_pose == session.frames.size()) {
    throw InputError(session_dir.string() +
                     ": no frame has a pose (run gonio locate; is the board visible?)");
  }
  size_t sample = 0;
  for (const auto& o : set.observations) sample += !o.white;
  if (sample == 0) {
    throw InputError(fmt::format("{}: no usable sample pixel (saturated {}, dark {}, on tags {})",
                                 session_dir.string(), count.saturated.load(), count.dark.load(),
                                 count.tag.load()));
  }
  spdlog::info(
      "extract: {} observations ({} sample, {} white); left out: saturated {}, dark {}, "
      "tag {}, frames without pose {}",
      set.observations.size(), sample, set.observations.size() - sample, count.saturated.load(),
      count.dark.load(), count.tag.load(), no_pose);
  return set;
}

}  // namespace gonio
