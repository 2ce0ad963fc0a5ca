#include "estimation/extract/extract.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <Eigen/Geometry>

#include "common/error.h"
#include "common/geometry.h"
#include "common/io.h"
#include "common/log.h"
#include "common/parallel.h"
#include "common/session_frames.h"

namespace gonio {
namespace {

// Pixel counts left out, shared by the worker threads of one frame.
struct Counters {
  std::atomic<size_t> saturated{0}, dark{0}, tag{0}, hidden{0};
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
  cv::Mat values;  // the raw pixel values, CV_32F with the frame's channels
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
  regions_.push_back({&board.sample_region(), false, -board.sample_height()});
  if (options.white_reference && board.white_region().size() >= 3) {
    regions_.push_back({&board.white_region(), true, 0.0});
  }
  tags_ = GrownTagSquares(board);
  set_.channels = photometric.response.channels;
  for (const auto& f : frames) set_.frame_files.push_back(f.file);
}

namespace {

// The patch origins whose pixels can fall in a region: the regions' corners projected into
// the image bound the pixel loop.
template <typename Region>
void BoundPatchLoop(const CameraModel& camera, const std::vector<Region>& regions, int patch,
                    FrameGeometry* g) {
  double umin = camera.width, umax = 0, vmin = camera.height, vmax = 0;
  for (const Region& r : regions) {
    for (const auto& q : *r.polygon) {
      const Eigen::Vector3d p_in_cam = g->cam_from_board * Eigen::Vector3d(q.x(), q.y(), r.z);
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

// Whether a region's projection overlaps the image at all (the box of its corners in front of
// the camera against the image).
template <typename Region>
bool RegionInView(const CameraModel& camera, const Region& r, const Rigid3d& cam_from_board) {
  double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
  for (const auto& q : *r.polygon) {
    const Eigen::Vector3d p_in_cam = cam_from_board * Eigen::Vector3d(q.x(), q.y(), r.z);
    if (p_in_cam.z() <= 0) continue;
    const Eigen::Vector2d px = camera.Project(p_in_cam);
    umin = std::min(umin, px.x());
    umax = std::max(umax, px.x());
    vmin = std::min(vmin, px.y());
    vmax = std::max(vmax, px.y());
  }
  return umax >= 0 && umin < camera.width && vmax >= 0 && vmin < camera.height;
}

// What every patch of every frame shares.
template <typename Region>
struct PatchContext {
  const CameraModel* camera;
  const std::vector<Region>* regions;
  const std::vector<std::vector<Eigen::Vector2d>>* tags;
  int channels, patch;
  double sample_height;
};

// Where a pixel's ray meets the plane z = plane_z (board frame), or false when it meets it
// behind the camera or not at all.
bool PlanePoint(const FrameGeometry& g, const Eigen::Vector3d& dir, double plane_z,
                Eigen::Vector3d* p) {
  if (std::abs(dir.z()) < 1e-12) return false;
  const double s = (plane_z - g.board_from_cam.t.z()) / dir.z();
  if (s <= 0) return false;
  *p = g.board_from_cam.t + s * dir;
  return true;
}

// Whether the ray from the camera to board point p (z = 0) passes through a sample raised by
// `height` (its top or its sides, within `margin`): points along the ray between the top's
// plane and the board, tested against the sample polygon.
bool HiddenBySample(const FrameGeometry& g, const std::vector<Eigen::Vector2d>& sample,
                    const Eigen::Vector3d& p, double height, double margin) {
  const Eigen::Vector3d to_camera = g.board_from_cam.t - p;
  if (!(to_camera.z() < 0)) return false;
  constexpr int kSteps = 8;
  for (int k = 0; k <= kSteps; ++k) {
    const Eigen::Vector3d q = p + (height * k / kSteps / -to_camera.z()) * to_camera;
    if (SignedDistanceInPolygon(sample, Eigen::Vector2d(q.x(), q.y())) > -margin) return true;
  }
  return false;
}

// The region a pixel's ray shows (index into ctx.regions, -1: none) and its point there: the
// sample on its own plane first (a raised sample stands in front of the board), then the
// others; a region point hidden behind the raised sample counts as none (`*hidden`).
template <typename Region>
int PixelRegion(const PatchContext<Region>& ctx, const FrameGeometry& g, int u, int v,
                Eigen::Vector3d* p, bool* hidden) {
  const Eigen::Vector3d dir = g.board_from_cam.R * ctx.camera->Unproject(Eigen::Vector2d(u, v));
  *hidden = false;
  for (size_t k = 0; k < ctx.regions->size(); ++k) {
    const Region& r = (*ctx.regions)[k];
    if (!PlanePoint(g, dir, r.z, p)) continue;
    if (SignedDistanceInPolygon(*r.polygon, Eigen::Vector2d(p->x(), p->y())) <= g.margin) continue;
    if (k > 0 && ctx.sample_height > 0 &&
        HiddenBySample(g, *(*ctx.regions)[0].polygon, *p, ctx.sample_height, g.margin)) {
      *hidden = true;
      return -1;
    }
    return static_cast<int>(k);
  }
  return -1;
}

// One patch x patch square at (u, v) into an observation: every pixel must fall inside the
// same region (by more than the margin), off the tags, and be validly exposed. The variance of
// the patch mean is the larger of the propagated pixel noise and the patch's own scatter
// (texture) divided by n.
template <typename Region>
bool ExtractPatch(const PatchContext<Region>& ctx, const FrameGeometry& g, const FrameImages& im,
                  int u, int v, Counters* count, Observation* o) {
  const int C = ctx.channels, P = ctx.patch;
  Eigen::Vector3d sum_p = Eigen::Vector3d::Zero();
  Eigen::Matrix2d sum_pp = Eigen::Matrix2d::Zero();
  std::vector<double> sum(C, 0.0), sum_sq(C, 0.0), sum_var(C, 0.0), sum_value(C, 0.0);
  int n = 0, region_kind = -1;
  // The raw values, where they map one to one onto the radiance's pixels and channels.
  const bool has_values = im.values.size() == im.radiance.size() && im.values.channels() == C;
  for (int dv = 0; dv < P; ++dv) {
    for (int du = 0; du < P; ++du) {
      Eigen::Vector3d p;
      bool hidden = false;
      const int kind = PixelRegion(ctx, g, u + du, v + dv, &p, &hidden);
      if (hidden) {
        ++count->hidden;
        return false;
      }
      const Eigen::Vector2d q(p.x(), p.y());
      if (kind < 0 || (region_kind >= 0 && kind != region_kind)) return false;
      region_kind = kind;
      for (const auto& t : *ctx.tags) {
        if (SignedDistanceInPolygon(t, q) > -g.margin) {
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
      const float* Z = has_values ? im.values.ptr<float>(v + dv) + (u + du) * C : nullptr;
      for (int c = 0; c < C; ++c) {
        if (Z) sum_value[c] += Z[c];
        sum[c] += L[c];
        sum_sq[c] += static_cast<double>(L[c]) * L[c];
        sum_var[c] += V[c];
      }
      sum_p += p;
      sum_pp += q * q.transpose();
      ++n;
    }
  }
  if (n == 0) return false;
  o->px = u + 0.5 * (P - 1);
  o->py = v + 0.5 * (P - 1);
  o->p_in_board = sum_p / n;
  // The pixel centres' scatter, widened from P x P points to the P x P pixels' area (per
  // axis (P^2 - 1) / 12 -> P^2 / 12 pixels^2): each pixel integrates its own square.
  if (n > 1) {
    const Eigen::Vector2d mean = o->p_in_board.head<2>();
    const double area = static_cast<double>(n) / (n - 1);
    o->patch_moment = (sum_pp / n - mean * mean.transpose()) * area;
  }
  o->p_in_board.z() = (*ctx.regions)[region_kind].z;
  o->camera_in_board = g.board_from_cam.t;
  o->board_from_cam_aa = g.board_from_cam_aa;
  o->white = (*ctx.regions)[region_kind].white;
  o->num_pixels = n;
  for (int c = 0; c < C; ++c) {
    const double mean = sum[c] / n;
    o->radiance.push_back(mean);
    if (has_values) o->value.push_back(sum_value[c] / n);
    const double scatter = n > 1 ? std::max(0.0, sum_sq[c] / n - mean * mean) * n / (n - 1) : 0.0;
    o->variance.push_back(std::max(sum_var[c] / n, scatter) / n);
  }
  return true;
}

}  // namespace

namespace {

// The lamp's own radiance: the lamp-off frame's radiance (same exposure and gain) subtracted,
// the two variances added. A lamp-off pixel at or below the black level is a valid reading of
// (nearly) no ambient light; a saturated one makes the pixel invalid.
void SubtractLampOff(const PhotometricCalibration& photometric, const cv::Mat& lamp_off,
                     const SessionFrame& frame, FrameImages* im) {
  FrameImages off;
  photometric.ToRadiance(lamp_off, frame.exposure_s, frame.gain, &off.radiance, &off.variance,
                         &off.valid);
  const int C = im->radiance.channels();
  const double max_value = (1 << photometric.response.bit_depth) - 1.0;
  cv::Mat values;
  lamp_off.convertTo(values, CV_MAKETYPE(CV_64F, C));
  for (int y = 0; y < values.rows; ++y) {
    const double* z = values.ptr<double>(y);
    float* L = im->radiance.ptr<float>(y);
    float* V = im->variance.ptr<float>(y);
    const float* L_off = off.radiance.ptr<float>(y);
    const float* V_off = off.variance.ptr<float>(y);
    uint8_t* ok = im->valid.ptr<uint8_t>(y);
    for (int x = 0; x < values.cols; ++x) {
      for (int c = 0; c < C; ++c) {
        const int i = x * C + c;
        if (z[i] >= std::min(max_value, photometric.response.saturation_level[c])) ok[x] = 0;
        L[i] -= L_off[i];
        V[i] += V_off[i];
      }
    }
  }
}

}  // namespace

void ObservationExtractor::AddFrame(size_t f, const cv::Mat& raw, const Rigid3d& cam_from_board,
                                    const std::string& what, const cv::Mat* lamp_off) {
  if (raw.empty()) throw InputError(what + ": cannot be read as an image");
  if (raw.cols != camera_.width || raw.rows != camera_.height) {
    throw InputError(what + ": image size differs from the camera model's");
  }
  if (lamp_off &&
      (lamp_off->empty() || lamp_off->size() != raw.size() || lamp_off->type() != raw.type())) {
    throw InputError(what + ": its lamp-off frame " + frames_[f].lamp_off +
                     " cannot be read or differs in size or type");
  }
  added_.at(f) = true;
  FrameGeometry g;
  g.cam_from_board = cam_from_board;
  g.board_from_cam = cam_from_board.Inverse();
  const Eigen::AngleAxisd aa(g.board_from_cam.R);
  g.board_from_cam_aa = aa.angle() * aa.axis();
  const double footprint = g.board_from_cam.t.norm() / camera_.intrinsics[0];
  g.margin = options_.edge_margin_px * footprint * options_.patch;
  BoundPatchLoop(camera_, regions_, options_.patch, &g);
  sample_in_view_ += RegionInView(camera_, regions_[0], cam_from_board);

  FrameImages im;
  photometric_.ToRadiance(raw, frames_[f].exposure_s, frames_[f].gain, &im.radiance, &im.variance,
                          &im.valid, options_.threads);
  // The values the radiances come from: the response's error is a function of the value (with
  // a lamp-off frame subtracted, the lamp-on frame's).
  raw.convertTo(im.values, CV_MAKETYPE(CV_32F, raw.channels()));
  if (lamp_off) {
    SubtractLampOff(photometric_, *lamp_off, frames_[f], &im);
    ++lamp_off_frames_;
  }
  const int P = options_.patch;
  const int rows = g.v1 >= g.v0 ? (g.v1 - g.v0) / P + 1 : 0;
  const PatchContext<Region> ctx{&camera_,      &regions_, &tags_,
                                 set_.channels, P,         board_.sample_height()};
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
  hidden_ += count.hidden.load();
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
  if (board_.sample_height() > 0) set_.excluded.emplace_back("hidden_by_sample", hidden_);
  set_.lamp_off_frames = lamp_off_frames_;
  if (no_pose == frames_.size()) {
    throw InputError(what + ": no frame has a pose (run gonio locate; is the board visible?)");
  }
  size_t sample = 0;
  for (const auto& o : set_.observations) sample += !o.white;
  if (sample == 0 && sample_in_view_ == 0) {
    throw InputError(fmt::format(
        "{}: the sample_region is in the view of no located frame (its corners project outside "
        "every image); does it lie on the board, in metres in the board's frame "
        "(docs/formats.md)?",
        board_.source_name()));
  }
  if (sample == 0) {
    throw InputError(fmt::format("{}: no usable sample pixel (saturated {}, dark {}, on tags {})",
                                 what, saturated_, dark_, tag_));
  }
  spdlog::info(
      "extract: {} observations ({} sample, {} white); left out: saturated {}, dark {}, "
      "tag {}, frames without pose {}",
      set_.observations.size(), sample, set_.observations.size() - sample, saturated_, dark_, tag_,
      no_pose);
  if (lamp_off_frames_ > 0) {
    spdlog::info("extract: lamp-off radiance subtracted in {} frames", lamp_off_frames_);
  }
  if (lamp_off_frames_ > 0 && lamp_off_frames_ + no_pose < frames_.size()) {
    spdlog::warn(
        "extract: only {} of {} frames have a lamp-off frame; the others include the "
        "room's light",
        lamp_off_frames_, frames_.size() - no_pose);
  }
  return std::move(set_);
}

ImageExpectation FrameExpectation(const Session& session, const PhotometricCalibration& photometric,
                                  const std::string& photometric_what, const CameraModel* camera,
                                  const std::string& camera_what) {
  ImageExpectation e;
  const bool stated = session.bit_depth > 0;
  e.bit_depth = stated ? session.bit_depth : photometric.response.bit_depth;
  e.bit_depth_of = stated ? (session.dir / "session.json").string() : photometric_what;
  e.channels = photometric.response.channels;
  e.channels_of = photometric_what;
  const cv::Size vignette = photometric.vignette.size();
  const std::string vignette_what = photometric.vignette_file.string();
  if (camera) {
    e.size = cv::Size(camera->width, camera->height);
    e.size_of = camera_what;
    if (!photometric.vignette.empty() && vignette != e.size) {
      throw InputError(fmt::format("{}: the vignetting map is {}x{}, {} is {}x{}", vignette_what,
                                   vignette.width, vignette.height, camera_what, e.size.width,
                                   e.size.height));
    }
  } else if (!photometric.vignette.empty()) {
    e.size = vignette;
    e.size_of = "the vignetting map " + vignette_what;
  }
  return e;
}

ObservationSet ExtractObservations(const std::filesystem::path& session_dir,
                                   const CameraModel& camera, const Board& board,
                                   const std::map<std::string, Rigid3d>& poses,
                                   const PhotometricCalibration& photometric,
                                   const ExtractOptions& options) {
  const Session session = ReadSession(session_dir);
  const ImageExpectation expect =
      FrameExpectation(session, photometric, "the photometric calibration", &camera, "the camera");
  ObservationExtractor extractor(session.frames, camera, board, photometric, options);
  SessionFrames frames(session, expect);
  frames.ForEach(
      "extract",
      [&](size_t f, const cv::Mat& image) {
        const cv::Mat lamp_off = frames.LampOff(f);
        extractor.AddFrame(f, image, poses.at(session.frames[f].file),
                           session.FramePath(f).string(), lamp_off.empty() ? nullptr : &lamp_off);
      },
      [&](size_t f) { return poses.count(session.frames[f].file) > 0; });
  return extractor.Finish(session_dir.string());
}

}  // namespace gonio
