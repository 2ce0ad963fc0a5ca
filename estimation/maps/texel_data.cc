#include "estimation/maps/texel_data.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "common/error.h"
#include "common/geometry.h"
#include "common/math.h"
#include "common/parallel.h"

namespace gonio {
namespace {

// The radiance images of one frame, and per pixel the shot-noise basis L / (t g V): shot
// noise in exposure units is proportional to the exposure X = L t g V, so its variance in
// radiance units is proportional to L / (t g V).
struct FrameImages {
  cv::Mat radiance, variance, valid, shot;
};

FrameImages Radiometry(const PhotometricCalibration& photometric, const cv::Mat& raw,
                       double exposure_s, double gain, int threads) {
  FrameImages im;
  photometric.ToRadiance(raw, exposure_s, gain, &im.radiance, &im.variance, &im.valid, threads);
  const int C = im.radiance.channels();
  im.shot = cv::Mat(im.radiance.size(), im.radiance.type());
  for (int y = 0; y < raw.rows; ++y) {
    const float* L = im.radiance.ptr<float>(y);
    float* q = im.shot.ptr<float>(y);
    const float* v = photometric.vignette.empty() ? nullptr : photometric.vignette.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x) {
      const double scale = 1.0 / (exposure_s * gain * (v ? std::max(v[x], 1e-3f) : 1.0f));
      for (int c = 0; c < C; ++c)
        q[x * C + c] = static_cast<float>(std::max(0.0f, L[x * C + c]) * scale);
    }
  }
  return im;
}

// Keys' cubic convolution weights (a = -1/2, Catmull-Rom) of the four taps around a sample at
// fraction f past the second tap: exact for quadratics, so the image's curvature (texture,
// shading) does not blur into the sample as it does with bilinear weights, whose mean error
// is h^2/12 times the radiance's Laplacian (1% of the albedo on a 10 mm texture seen at 1.7 mm
// per pixel, as a grazing 640x480 view of the textured preset is).
void CubicWeights(double f, double w[4]) {
  const double f2 = f * f, f3 = f2 * f;
  w[0] = -0.5 * f3 + f2 - 0.5 * f;
  w[1] = 1.5 * f3 - 2.5 * f2 + 1;
  w[2] = -1.5 * f3 + 2 * f2 + 0.5 * f;
  w[3] = 0.5 * f3 - 0.5 * f2;
}

// Cubic-convolution sample of the images at pixel (u, v) into out[channel] (R, G, B order),
// variances weighted by w^2 (independent pixel noise). False unless all 16 taps are valid.
bool Interpolate(const FrameImages& im, double u, double v, float* radiance, float* var_read,
                 float* var_shot) {
  const int x0 = static_cast<int>(std::floor(u)) - 1, y0 = static_cast<int>(std::floor(v)) - 1;
  if (x0 < 0 || y0 < 0 || x0 + 3 >= im.radiance.cols || y0 + 3 >= im.radiance.rows) return false;
  const int C = im.radiance.channels();
  double wx[4], wy[4];
  CubicWeights(u - (x0 + 1), wx);
  CubicWeights(v - (y0 + 1), wy);
  double L[3] = {0, 0, 0}, V[3] = {0, 0, 0}, Q[3] = {0, 0, 0};
  for (int j = 0; j < 4; ++j) {
    const int y = y0 + j;
    const uint8_t* valid = im.valid.ptr<uint8_t>(y);
    const float* r = im.radiance.ptr<float>(y);
    const float* var = im.variance.ptr<float>(y);
    const float* q = im.shot.ptr<float>(y);
    for (int i = 0; i < 4; ++i) {
      const int x = x0 + i;
      if (!valid[x]) return false;
      const double w = wx[i] * wy[j];
      for (int c = 0; c < C; ++c) {
        L[c] += w * r[x * C + c];
        V[c] += w * w * var[x * C + c];
        Q[c] += w * w * q[x * C + c];
      }
    }
  }
  for (int c = 0; c < C; ++c) {
    const int out = C == 3 ? 2 - c : c;  // OpenCV's B, G, R -> R, G, B
    radiance[out] = static_cast<float>(L[c]);
    var_read[out] = static_cast<float>(V[c]);
    var_shot[out] = static_cast<float>(Q[c]);
  }
  return true;
}

}  // namespace

TexelGrid GridOver(const std::vector<Eigen::Vector2d>& region, double texel, double plane_z,
                   double margin, std::vector<uint8_t>* mask) {
  Eigen::Vector2d lo = region[0], hi = region[0];
  for (const auto& p : region) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  TexelGrid g;
  g.texel = texel;
  g.plane_z = plane_z;
  g.width = std::max(1, static_cast<int>(std::floor((hi.x() - lo.x()) / texel)));
  g.height = std::max(1, static_cast<int>(std::floor((hi.y() - lo.y()) / texel)));
  // Centred in the box.
  g.origin = 0.5 * (lo + hi) - 0.5 * texel * Eigen::Vector2d(g.width - 1, g.height - 1);
  mask->assign(g.size(), 0);
  for (size_t k = 0; k < g.size(); ++k) {
    (*mask)[k] = SignedDistanceInPolygon(region, g.Centre(k).head<2>()) > margin;
  }
  return g;
}

size_t TexelData::masked_texels() const {
  return static_cast<size_t>(std::count(mask.begin(), mask.end(), 1));
}

size_t TexelData::InvalidateNonFinite() {
  auto bad = [](float L, float var_read, float var_shot) {
    return !std::isfinite(L) || !(var_read >= 0) || !(var_shot >= 0) || !std::isfinite(var_read) ||
           !std::isfinite(var_shot);
  };
  size_t n = 0;
  for (ViewSamples& s : samples) {
    size_t in_view = 0;
    for (size_t t = 0; t < s.valid.size(); ++t) {
      if (!s.valid[t]) continue;
      bool invalid = false;
      for (int c = 0; c < channels; ++c) {
        const size_t i = t * channels + c;
        invalid = invalid || bad(s.radiance[i], s.var_read[i], s.var_shot[i]);
      }
      s.valid[t] = !invalid;
      in_view += invalid;
    }
    if (in_view) s.count = static_cast<size_t>(std::count(s.valid.begin(), s.valid.end(), 1));
    n += in_view;
  }
  const size_t white_before = white.size();
  white.erase(std::remove_if(white.begin(), white.end(),
                             [&](const WhiteSample& w) {
                               bool invalid = false;
                               for (int c = 0; c < channels; ++c)
                                 invalid =
                                     invalid || bad(w.radiance[c], w.var_read[c], w.var_shot[c]);
                               return invalid;
                             }),
              white.end());
  return n + (white_before - white.size());
}

void TexelSamplingOptions::Check() const {
  if (!(texel_m >= 0 && texel_m <= 0.05)) throw InputError("--texel: must be in (0, 50] mm");
  if (!(edge_margin_px >= 0)) throw InputError("maps: the edge margin must be >= 0");
  if (!(white_spacing_m > 0)) throw InputError("maps: the white-reference spacing must be > 0");
  if (!(max_view_angle_deg > 0 && max_view_angle_deg < 90)) {
    throw InputError("maps: the largest view angle must be in (0, 90) deg");
  }
}

double TexelData::SampleReach(size_t v, const Eigen::Vector3d& p,
                              const Eigen::Vector2d& towards) const {
  const Eigen::Vector3d to_cam = views[v].camera_in_board - p;
  // Along `towards` the ellipse reaches a sqrt(1 + tan^2(theta) (towards . tilt)^2), tilt the
  // unit direction of to_cam in the plane: (towards . to_cam_xy / to_cam_z)^2 under the root.
  const double along = towards.dot(to_cam.head<2>()) / std::max(std::abs(to_cam.z()), 1e-9);
  const double extent = views[v].support_rad * to_cam.norm() * std::sqrt(1 + along * along);
  return std::max(reach_m, extent + 0.5 * grid.texel);
}

double TexelData::SampleReach(size_t v, const Eigen::Vector3d& p) const {
  const Eigen::Vector2d tilt = (views[v].camera_in_board - p).head<2>();
  return SampleReach(v, p, tilt.norm() > 0 ? tilt.normalized() : Eigen::Vector2d::UnitX());
}

// Per texel of `grid`, how far inside `region` its centre lies and the direction to the
// region's edge (down the distance's gradient, by central differences).
std::vector<TexelSampler::Inside> TexelSampler::InsideOf(const std::vector<Eigen::Vector2d>& region,
                                                         const TexelGrid& grid) {
  std::vector<Inside> inside(grid.size());
  const double h = 1e-3 * grid.texel;
  for (size_t t = 0; t < grid.size(); ++t) {
    const Eigen::Vector2d c = grid.Centre(t).head<2>();
    const double d = SignedDistanceInPolygon(region, c);
    const Eigen::Vector2d gradient(SignedDistanceInPolygon(region, c + Eigen::Vector2d(h, 0)) -
                                       SignedDistanceInPolygon(region, c - Eigen::Vector2d(h, 0)),
                                   SignedDistanceInPolygon(region, c + Eigen::Vector2d(0, h)) -
                                       SignedDistanceInPolygon(region, c - Eigen::Vector2d(0, h)));
    inside[t].distance_m = static_cast<float>(d);
    if (gradient.norm() > 0) inside[t].towards_edge = (-gradient.normalized()).cast<float>();
  }
  return inside;
}

bool TexelSampler::Clear(const Inside& in, size_t view, const Eigen::Vector3d& p) const {
  return in.distance_m >= data_.SampleReach(view, p, in.towards_edge.cast<double>());
}

TexelSampler::TexelSampler(const CameraModel& camera, const Board& board,
                           const PhotometricCalibration& photometric,
                           const std::vector<Pose>& poses, const TexelSamplingOptions& options)
    : camera_(camera), photometric_(photometric), poses_(poses), options_(options) {
  options.Check();
  if (board.sample_region().size() < 3) {
    throw InputError("board file has no sample_region: no texels to map");
  }
  if (poses.empty()) throw InputError("maps: no located frame");
  const auto& region = board.sample_region();
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& p : region) centre += p;
  centre /= static_cast<double>(region.size());
  const double plane_z = -board.sample_height();
  // Pixel footprint at the sample's centre per view (distance / focal length): the texel, and
  // the margin that keeps every texel's pixels on the sample.
  std::vector<double> footprints;
  for (const auto& p : poses) {
    const Eigen::Vector3d c = p.cam_from_board * Eigen::Vector3d(centre.x(), centre.y(), plane_z);
    footprints.push_back(c.norm() / camera.intrinsics[0]);
  }
  std::nth_element(footprints.begin(), footprints.begin() + footprints.size() / 2,
                   footprints.end());
  const double footprint = footprints[footprints.size() / 2];
  const double texel = options.texel_m > 0 ? options.texel_m : footprint;
  const double margin = options.edge_margin_px * footprint + 0.5 * texel;
  data_.grid = GridOver(region, texel, plane_z, margin, &data_.mask);
  data_.reach_m = margin;
  inside_ = InsideOf(region, data_.grid);
  data_.channels = photometric.response.channels;
  if (data_.channels != 1 && data_.channels != 3) {
    throw InputError("maps: the photometric calibration has " + std::to_string(data_.channels) +
                     " channels (1 or 3 needed)");
  }
  if (board.white_region().size() >= 3) {
    white_grid_ =
        GridOver(board.white_region(), options.white_spacing_m, 0.0, margin, &white_mask_);
    white_inside_ = InsideOf(board.white_region(), white_grid_);
  }
  data_.views.resize(poses.size());
  data_.samples.resize(poses.size());
  for (auto& view : data_.views) view.support_rad = options.edge_margin_px / camera.intrinsics[0];
}

void TexelSampler::AddFrame(
    size_t k, const cv::Mat& raw, const std::string& what,
    const std::function<Eigen::Vector2d(const Eigen::Vector3d&)>* displacement) {
  if (raw.cols != camera_.width || raw.rows != camera_.height) {
    throw InputError(what + ": image size differs from the camera model's");
  }
  const Pose& pose = poses_.at(k);
  const FrameImages im =
      Radiometry(photometric_, raw, pose.exposure_s, pose.gain, options_.threads);
  TexelView& view = data_.views[k];
  view.name = pose.file;
  view.board_from_cam = pose.cam_from_board.Inverse();
  view.camera_in_board = view.board_from_cam.t;
  const double cos_max = std::cos(DegToRad(options_.max_view_angle_deg));
  const int C = data_.channels;
  // Whether a board point is seen at a usable angle and where it projects.
  auto project = [&](const Eigen::Vector3d& p, Eigen::Vector2d* px) {
    const Eigen::Vector3d to_cam = view.camera_in_board - p;
    if (!(-to_cam.z() > cos_max * to_cam.norm())) return false;  // outward normal is -z
    const Eigen::Vector3d q = pose.cam_from_board * p;
    if (q.z() <= 0) return false;
    *px = camera_.Project(q);
    return true;
  };
  ViewSamples& s = data_.samples[k];
  const size_t n = data_.grid.size();
  s.radiance.assign(n * C, 0.f);
  s.var_read.assign(n * C, 0.f);
  s.var_shot.assign(n * C, 0.f);
  s.valid.assign(n, 0);
  ParallelFor(n, options_.threads, [&](size_t b, size_t e) {
    for (size_t t = b; t < e; ++t) {
      Eigen::Vector2d px;
      if (!data_.mask[t]) continue;
      Eigen::Vector3d p = data_.grid.Centre(t);
      if (displacement) p.head<2>() += (*displacement)(p);
      if (!Clear(inside_[t], k, p) || !project(p, &px)) continue;
      s.valid[t] = Interpolate(im, px.x(), px.y(), &s.radiance[t * C], &s.var_read[t * C],
                               &s.var_shot[t * C]);
    }
  });
  s.count = static_cast<size_t>(std::count(s.valid.begin(), s.valid.end(), 1));
  for (size_t t = 0; t < white_grid_.size(); ++t) {
    Eigen::Vector2d px;
    const Eigen::Vector3d p = white_grid_.Centre(t);
    WhiteSample w;
    if (!white_mask_[t] || !Clear(white_inside_[t], k, p) || !project(p, &px)) continue;
    if (!Interpolate(im, px.x(), px.y(), w.radiance.data(), w.var_read.data(), w.var_shot.data())) {
      continue;
    }
    w.view = static_cast<int>(k);
    w.p_in_board = p;
    data_.white.push_back(w);
  }
}

TexelData TexelSampler::Finish(const std::string& what) {
  size_t seen = 0;
  for (const auto& s : data_.samples) seen += s.count;
  if (seen == 0) {
    throw InputError(what + ": no texel of the sample region is seen in a located frame");
  }
  return std::move(data_);
}

}  // namespace gonio
