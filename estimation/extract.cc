#include "estimation/extract.h"

#include <algorithm>
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

// Pixel counts left out, shared by the worker threads of one frame.
struct Counters {
  std::atomic<size_t> saturated{0}, dark{0}, tag{0};
};

// What one frame's pixel loop needs, computed once per frame.
struct FrameGeometry {
  Rigid3d cam_from_board, board_from_cam;
  Eigen::Vector3d board_from_cam_aa;
  double margin = 0;                     // region and tag margin on the board, metres
  int u0 = 0, u1 = -1, v0 = 0, v1 = -1;  // patch origins to visit
};

// The radiance, variance and validity images of one frame.
struct FrameImages {
  cv::Mat radiance, variance, valid;
};

// Tag squares grown by one module of the tag's white border: those pixels are never sample.
std::vector<std::vector<Eigen::Vector2d>> GrownTagSquares(const Board& board) {
  std::vector<std::vector<Eigen::Vector2d>> tags;
  if (board.is_chessboard()) return tags;
  const double grow = board.tag_size() / 8.0;
  const double s = board.tag_size();
  for (size_t k = 0; k < board.ids().size(); ++k) {
    if (board.ids()[k] < 0) continue;
    const Eigen::Vector3d& tl = board.Points()[Board::TagPointIndex(static_cast<int>(k), 3)];
    tags.push_back({{tl.x() - grow, tl.y() - grow},
                    {tl.x() + s + grow, tl.y() - grow},
                    {tl.x() + s + grow, tl.y() + s + grow},
                    {tl.x() - grow, tl.y() + s + grow}});
  }
  return tags;
}

}  // namespace

void ExtractOptions::Check() const {
  if (patch < 1 || patch > 64) throw InputError("--patch must be in [1, 64]");
  if (!(edge_margin_px >= 0)) throw InputError("edge margin must be >= 0");
}

ObservationExtractor::ObservationExtractor(const std::vector<SessionFrame>& frames,
                                           const CameraModel& camera, const Board& board,
                                           const PhotometricCalibration& photometric,
                                           const ExtractOptions& options)
    : frames_(frames),
      camera_(camera),
      board_(board),
      photometric_(photometric),
      options_(options),
      added_(frames.size(), false) {
  options_.Check();
  if (board.sample_region().size() < 3) {
    throw InputError("board file has no sample_region: nothing to extract");
  }
  regions_.emplace_back(&board.sample_region(), false);
  if (options.white_reference && board.white_region().size() >= 3) {
    regions_.emplace_back(&board.white_region(), true);
  }
  tags_ = GrownTagSquares(board);
  set_.channels = photometric.response.channels;
  for (const auto& f : frames) set_.frame_files.push_back(f.file);
}

namespace {

// The patch origins whose pixels can fall in a region: the regions' corners projected into
// the image bound the pixel loop.
void BoundPatchLoop(const CameraModel& camera,
                    const std::vector<const std::vector<Eigen::Vector2d>*>& polys, int patch,
                    FrameGeometry* g) {
  double umin = camera.width, umax = 0, vmin = camera.height, vmax = 0;
  for (const auto* poly : polys) {
    for (const auto& q : *poly) {
      const Eigen::Vector3d p_in_cam = g->cam_from_board * Eigen::Vector3d(q.x(), q.y(), 0.0);
      if (p_in_cam.z() <= 0) continue;
      const Eigen::Vector2d px = camera.Project(p_in_cam);
      umin = std::min(umin, px.x());
      umax = std::max(umax, px.x());
      vmin = std::min(vmin, px.y());
      vmax = std::max(vmax, px.y());
    }
  }
  g->u0 = std::max(0, static_cast<int>(umin) - 2);
  g->u1 = std::min(camera.width - patch, static_cast<int>(umax) + 2);
  g->v0 = std::max(0, static_cast<int>(vmin) - 2);
  g->v1 = std::min(camera.height - patch, static_cast<int>(vmax) + 2);
}

// What every patch of every frame shares.
struct PatchContext {
  const CameraModel* camera;
  const std::vector<std::pair<const std::vector<Eigen::Vector2d>*, bool>>* regions;
  const std::vector<std::vector<Eigen::Vector2d>>* tags;
  int channels, patch;
};

// The board point a pixel's ray meets, or false when the ray misses the board's front.
bool BoardPoint(const CameraModel& camera, const FrameGeometry& g, int u, int v,
                Eigen::Vector3d* p) {
  const Eigen::Vector3d ray_in_cam = camera.Unproject(Eigen::Vector2d(u, v));
  const Eigen::Vector3d dir = g.board_from_cam.R * ray_in_cam;
  if (std::abs(dir.z()) < 1e-12) return false;
  const double s = -g.board_from_cam.t.z() / dir.z();
  if (s <= 0) return false;
  *p = g.board_from_cam.t + s * dir;
  return true;
}

// One patch x patch square at (u, v) into an observation: every pixel must fall inside the
// same region (by more than the margin), off the tags, and be validly exposed. The variance of
// the patch mean is the larger of the propagated pixel noise and the patch's own scatter
// (texture) divided by n.
bool ExtractPatch(const PatchContext& ctx, const FrameGeometry& g, const FrameImages& im, int u,
                  int v, Counters* count, Observation* o) {
  const int C = ctx.channels, P = ctx.patch;
  Eigen::Vector3d sum_p = Eigen::Vector3d::Zero();
  std::vector<double> sum(C, 0.0), sum_sq(C, 0.0), sum_var(C, 0.0);
  int n = 0, region_kind = -1;
  for (int dv = 0; dv < P; ++dv) {
    for (int du = 0; du < P; ++du) {
      Eigen::Vector3d p;
      if (!BoardPoint(*ctx.camera, g, u + du, v + dv, &p)) return false;
      const Eigen::Vector2d q(p.x(), p.y());
      int kind = -1;
      for (size_t k = 0; k < ctx.regions->size(); ++k) {
        if (InsideDistance(*(*ctx.regions)[k].first, q) > g.margin) kind = static_cast<int>(k);
      }
      if (kind < 0 || (region_kind >= 0 && kind != region_kind)) return false;
      region_kind = kind;
      for (const auto& t : *ctx.tags) {
        if (InsideDistance(t, q) > -g.margin) {
          ++count->tag;
          return false;
        }
      }
      const float* L = im.radiance.ptr<float>(v + dv) + (u + du) * C;
      if (!im.valid.at<uint8_t>(v + dv, u + du)) {
        (L[0] > 0 ? count->saturated : count->dark)++;
        return false;
      }
      const float* V = im.variance.ptr<float>(v + dv) + (u + du) * C;
      for (int c = 0; c < C; ++c) {
        sum[c] += L[c];
        sum_sq[c] += static_cast<double>(L[c]) * L[c];
        sum_var[c] += V[c];
      }
      sum_p += p;
      ++n;
    }
  }
  if (n == 0) return false;
  o->px = u + 0.5 * (P - 1);
  o->py = v + 0.5 * (P - 1);
  o->p_in_board = sum_p / n;
  o->p_in_board.z() = 0.0;
  o->camera_in_board = g.board_from_cam.t;
  o->board_from_cam_aa = g.board_from_cam_aa;
  o->white = (*ctx.regions)[region_kind].second;
  o->num_pixels = n;
  for (int c = 0; c < C; ++c) {
    const double mean = sum[c] / n;
    o->radiance.push_back(mean);
    const double scatter = n > 1 ? std::max(0.0, sum_sq[c] / n - mean * mean) * n / (n - 1) : 0.0;
    o->variance.push_back(std::max(sum_var[c] / n, scatter) / n);
  }
  return true;
}

}  // namespace

void ObservationExtractor::AddFrame(size_t f, const cv::Mat& raw, const Rigid3d& cam_from_board,
                                    const std::string& what) {
  if (raw.empty()) throw InputError(what + ": cannot be read as an image");
  if (raw.cols != camera_.width || raw.rows != camera_.height) {
    throw InputError(what + ": image size differs from the camera model's");
  }
  added_.at(f) = true;
  FrameGeometry g;
  g.cam_from_board = cam_from_board;
  g.board_from_cam = cam_from_board.Inverse();
  const Eigen::AngleAxisd aa(g.board_from_cam.R);
  g.board_from_cam_aa = aa.angle() * aa.axis();
  const double footprint = g.board_from_cam.t.norm() / camera_.intrinsics[0];
  g.margin = options_.edge_margin_px * footprint * options_.patch;
  std::vector<const std::vector<Eigen::Vector2d>*> polys;
  for (const auto& r : regions_) polys.push_back(r.first);
  BoundPatchLoop(camera_, polys, options_.patch, &g);

  FrameImages im;
  photometric_.ToRadiance(raw, frames_[f].exposure_s, frames_[f].gain, &im.radiance, &im.variance,
                          &im.valid);
  const int P = options_.patch;
  const int rows = g.v1 >= g.v0 ? (g.v1 - g.v0) / P + 1 : 0;
  const PatchContext ctx{&camera_, &regions_, &tags_, set_.channels, P};
  Counters count;
  std::mutex mutex;
  ParallelFor(rows, options_.threads, [&](size_t rb, size_t re) {
    std::vector<Observation> local;
    for (size_t r = rb; r < re; ++r) {
      const int v = g.v0 + static_cast<int>(r) * P;
      for (int u = g.u0; u <= g.u1; u += P) {
        Observation o;
        if (ExtractPatch(ctx, g, im, u, v, &count, &o)) {
          o.frame = static_cast<int>(f);
          local.push_back(std::move(o));
        }
      }
    }
    std::lock_guard<std::mutex> lock(mutex);
    set_.observations.insert(set_.observations.end(), local.begin(), local.end());
  });
  saturated_ += count.saturated.load();
  dark_ += count.dark.load();
  tag_ += count.tag.load();
}
ObservationSet ObservationExtractor::Finish(const std::string& what) {
  // Threads append in any order: sort so output is reproducible.
  std::sort(set_.observations.begin(), set_.observations.end(),
            [](const Observation& a, const Observation& b) {
              return std::tie(a.frame, a.py, a.px) < std::tie(b.frame, b.py, b.px);
            });
  const size_t no_pose = std::count(added_.begin(), added_.end(), false);
  set_.excluded = {
      {"saturated", saturated_}, {"dark", dark_}, {"tag", tag_}, {"frames_without_pose", no_pose}};
  if (no_pose == frames_.size()) {
    throw InputError(what + ": no frame has a pose (run gonio locate; is the board visible?)");
  }
  size_t sample = 0;
  for (const auto& o : set_.observations) sample += !o.white;
  if (sample == 0) {
    throw InputError(fmt::format("{}: no usable sample pixel (saturated {}, dark {}, on tags {})",
                                 what, saturated_, dark_, tag_));
  }
  spdlog::info(
      "extract: {} observations ({} sample, {} white); left out: saturated {}, dark {}, "
      "tag {}, frames without pose {}",
      set_.observations.size(), sample, set_.observations.size() - sample, saturated_, dark_, tag_,
      no_pose);
  return std::move(set_);
}

ObservationSet ExtractObservations(const std::filesystem::path& session_dir,
                                   const CameraModel& camera, const Board& board,
                                   const std::map<std::string, Rigid3d>& poses,
                                   const PhotometricCalibration& photometric,
                                   const ExtractOptions& options) {
  const Session session = ReadSession(session_dir);
  ObservationExtractor extractor(session.frames, camera, board, photometric, options);
  Progress progress("extract", session.frames.size());
  for (size_t f = 0; f < session.frames.size(); ++f) {
    const auto pose_it = poses.find(session.frames[f].file);
    if (pose_it != poses.end()) {
      const std::string path = session.FramePath(f).string();
      extractor.AddFrame(f, cv::imread(path, cv::IMREAD_UNCHANGED), pose_it->second, path);
    }
    progress.Step();
  }
  progress.Done();
  return extractor.Finish(session_dir.string());
}

}  // namespace gonio
