// `gonio plan`: candidates, predicted observations, selection (pipeline/plan.h, docs/plan.md).
#include "pipeline/plan.h"

#include <algorithm>
#include <cmath>
#include <mutex>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/math.h"
#include "common/option_words.h"
#include "common/parallel.h"
#include "data_synth/photometric.h"

namespace gonio {
namespace {

constexpr OptionWord<DesignCriterion> kCriterionWords[] = {{DesignCriterion::kD, "d"},
                                                           {DesignCriterion::kA, "a"}};

Eigen::Vector3d Centroid(const std::vector<Eigen::Vector2d>& poly) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& q : poly) c += Eigen::Vector3d(q.x(), q.y(), 0.0);
  return c / static_cast<double>(std::max<size_t>(1, poly.size()));
}

// The camera sees every tag corner and the whole sample region, 2% inside the image.
bool Reachable(const Rigid3d& cam_from_board, const CameraModel& camera, const Board& board) {
  std::vector<Eigen::Vector3d> points = board.Points();
  for (const auto& q : board.sample_region()) points.emplace_back(q.x(), q.y(), 0.0);
  const double mu = 0.02 * camera.width, mv = 0.02 * camera.height;
  for (const auto& p : points) {
    const Eigen::Vector3d p_in_cam = cam_from_board * p;
    if (p_in_cam.z() < 0.05) return false;
    const Eigen::Vector2d px = camera.Project(p_in_cam);
    if (!(px.x() > mu && px.x() < camera.width - 1 - mu && px.y() > mv &&
          px.y() < camera.height - 1 - mv)) {
      return false;
    }
  }
  return true;
}

struct Region {
  std::vector<cv::Point2f> contour;
  bool white;
};

// The pixel range the regions' corners project to.
void RegionBounds(const std::vector<Region>& regions, const Rigid3d& cam_from_board,
                  const CameraModel& camera, int patch, int* u0, int* u1, int* v0, int* v1) {
  std::vector<cv::Point2f> corners;
  for (const auto& r : regions) {
    for (const auto& q : r.contour) {
      const Eigen::Vector3d p_in_cam = cam_from_board * Eigen::Vector3d(q.x, q.y, 0.0);
      if (p_in_cam.z() <= 0) continue;
      const Eigen::Vector2d px = camera.Project(p_in_cam);
      corners.emplace_back(std::clamp<double>(px.x(), -1, camera.width),
                           std::clamp<double>(px.y(), -1, camera.height));
    }
  }
  const cv::Rect box = corners.empty() ? cv::Rect() : cv::boundingRect(corners);
  *u0 = std::max(0, box.x);
  *u1 = std::min(camera.width - patch, box.x + box.width);
  *v0 = std::max(0, box.y);
  *v1 = std::min(camera.height - patch, box.y + box.height);
  if (corners.empty()) *u1 = *v1 = -1;
}

// Variance of one pixel's relative exposure X: shot noise, read noise and quantization through
// the response (scene.h PhotometricSpec, as data_synth renders it).
double RelativeExposureVariance(const synth::PhotometricChain& chain,
                                const synth::PhotometricSpec& s, double x) {
  const double h = 1e-4;
  const double slope =
      (chain.Response(std::min(1.0, x + h)) - chain.Response(std::max(0.0, x - h))) /
      (std::min(1.0, x + h) - std::max(0.0, x - h));
  const double dn_per_x = std::max(slope, 1e-9) * (chain.max_value() - s.black_level);
  const double read = s.read_noise_e / s.full_well_e;
  return x / s.full_well_e + read * read + 1.0 / (12.0 * dn_per_x * dn_per_x);
}

}  // namespace

DesignCriterion ParseDesignCriterion(const std::string& word, const std::string& option_name) {
  return ParseOptionWord(kCriterionWords, word, option_name);
}

std::string ToString(DesignCriterion criterion) { return OptionWordOf(kCriterionWords, criterion); }

void PlanOptions::Check() const {
  hypothesis.Check();
  fit.Check();
  extract.Check();
  if (hypothesis.lamp_frame == LampFrame::kBoard && !(hypothesis.lamp.z() < 0)) {
    throw InputError(
        "--lamp: z must be negative (the lamp in front of the board, docs/conventions.md)");
  }
  if (views < 1 || views > 200) throw InputError("--views must be in [1, 200]");
  if (white_albedo && !(*white_albedo > 0 && *white_albedo <= 1)) {
    throw InputError("--white-albedo must be in (0, 1]");
  }
  if (!(exposure_s > 0 && std::isfinite(exposure_s))) {
    throw InputError("--exposure must be a positive number of seconds");
  }
  for (double p : polar_deg) {
    if (!(p >= 0 && p < 89)) throw InputError("--polar: angles must be in [0, 89) degrees");
  }
  for (double d : distances_m) {
    if (!(d > 0.01 && d < 100)) throw InputError("--distances: must be in (0.01, 100) m");
  }
  if (polar_deg.empty() || distances_m.empty() || azimuths < 1) {
    throw InputError("--polar, --distances and --azimuths must give at least one candidate");
  }
  if (!(saturation_level > 0 && saturation_level <= 1)) {
    throw InputError("saturation level must be in (0, 1]");
  }
  if (max_patches_per_view < 10) throw InputError("max patches per view must be >= 10");
  synth::Scene probe;
  probe.photometric = sensor;
  probe.Check();
}

PlannedView PredictView(const Rigid3d& cam_from_board, const CameraModel& camera,
                        const Board& board, const PlanOptions& o) {
  PlannedView view;
  view.cam_from_board = cam_from_board;
  const Rigid3d board_from_cam = cam_from_board.Inverse();
  const Eigen::AngleAxisd aa(board_from_cam.R);
  const Eigen::Vector3d target = Centroid(board.sample_region());
  const Eigen::Vector3d dir = board_from_cam.t - target;
  view.distance_m = dir.norm();
  view.polar_deg = RadToDeg(std::acos(std::clamp(-dir.z() / dir.norm(), -1.0, 1.0)));
  view.azimuth_deg = RadToDeg(std::atan2(dir.y(), dir.x()));
  if (view.azimuth_deg < 0) view.azimuth_deg += 360;

  std::vector<Region> regions;
  auto add_region = [&](const std::vector<Eigen::Vector2d>& poly, bool white) {
    Region r{{}, white};
    for (const auto& q : poly) r.contour.emplace_back(q.x(), q.y());
    regions.push_back(r);
  };
  add_region(board.sample_region(), false);
  if (o.white_albedo && board.white_region().size() >= 3) add_region(board.white_region(), true);
  const int P = o.extract.patch;
  int u0, u1, v0, v1;
  RegionBounds(regions, cam_from_board, camera, P, &u0, &u1, &v0, &v1);
  const double positions =
      std::max(0.0, (u1 - u0) / double(P) + 1) * std::max(0.0, (v1 - v0) / double(P) + 1);
  const int k =
      std::max(1, static_cast<int>(std::ceil(std::sqrt(positions / o.max_patches_per_view))));
  const double weight = static_cast<double>(k) * k;
  const double footprint = view.distance_m / camera.intrinsics[0];
  const double margin = o.extract.edge_margin_px * footprint * P;
  const synth::PhotometricChain chain(o.sensor, camera);
  const double scale = o.sensor.exposure_scale * o.exposure_s;

  ObservationSet set;
  std::vector<double> weights;
  for (int v = v0; v <= v1; v += P * k) {
    for (int u = u0; u <= u1; u += P * k) {
      const Eigen::Vector2d px(u + 0.5 * (P - 1), v + 0.5 * (P - 1));
      const Eigen::Vector3d ray = board_from_cam.R * camera.Unproject(px);
      if (std::abs(ray.z()) < 1e-12) continue;
      const double s = -board_from_cam.t.z() / ray.z();
      if (s <= 0) continue;
      const Eigen::Vector3d p = board_from_cam.t + s * ray;
      const Region* hit = nullptr;
      for (const auto& r : regions) {
        if (cv::pointPolygonTest(r.contour, cv::Point2f(p.x(), p.y()), true) > margin) hit = &r;
      }
      if (!hit) continue;
      Observation obs;
      obs.px = px.x();
      obs.py = px.y();
      obs.p_in_board = Eigen::Vector3d(p.x(), p.y(), 0.0);
      obs.camera_in_board = board_from_cam.t;
      obs.board_from_cam_aa = aa.angle() * aa.axis();
      obs.white = hit->white;
      obs.num_pixels = P * P;
      const double L = PredictRadiance(obs, o.hypothesis, o.white_albedo);
      const double x_per_l = scale * chain.Vignetting(px.x(), px.y());
      const double x = x_per_l * L;
      if (!(L > 0) || x * o.sensor.full_well_e < 1) continue;
      if (x > o.saturation_level) {
        view.saturated += static_cast<size_t>(weight);
        continue;
      }
      const double var_x = RelativeExposureVariance(chain, o.sensor, x);
      obs.radiance = {L};
      obs.variance = {var_x / (x_per_l * x_per_l) / (P * P)};
      set.observations.push_back(std::move(obs));
      weights.push_back(weight);
    }
  }
  view.patches = static_cast<size_t>(weight * set.observations.size());
  // The lamp columns' scale as the fit sets it: the fitted lamp vector (in its own frame) minus a
  // sample point (joint_fit.cc AnalyzeJointUncertainty).
  const double lamp_range = (o.hypothesis.lamp - target).norm();
  view.information = ObservationInformation(set, weights, o.hypothesis, lamp_range, o.fit);
  return view;
}

namespace {

// The views' information summed and scaled to the fit's observation cap.
DesignInformation SumInformation(const std::vector<const PlannedView*>& views,
                                 const PlanOptions& o) {
  DesignInformation sum;
  for (const PlannedView* v : views) sum.Add(v->information);
  const double cap = static_cast<double>(o.fit.final_max_observations);
  if (sum.observations > cap) sum.Scale(cap / sum.observations);
  return sum;
}

// Lower is better: log det (D) or trace (A) of the range-scaled scatter covariance
// A^-1 B A^-1, A regularised by a small ridge so sets that leave a direction unseen still
// compare (the direction then dominates the value).
double Criterion(const DesignInformation& info, DesignCriterion criterion) {
  const int p = static_cast<int>(info.names.size());
  if (p == 0) return INFINITY;
  Eigen::VectorXd range(p);
  for (int k = 0; k < p; ++k) range[k] = info.ranges[k] > 0 ? info.ranges[k] : 1.0;
  Eigen::MatrixXd a = range.asDiagonal() * info.fit_information * range.asDiagonal();
  const Eigen::MatrixXd b = range.asDiagonal() * info.noise_information * range.asDiagonal();
  a += Eigen::MatrixXd::Identity(p, p) * (1e-9 * std::max(a.trace() / p, 1e-300));
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(a);
  const Eigen::MatrixXd a_inv = ldlt.solve(Eigen::MatrixXd::Identity(p, p));
  const Eigen::MatrixXd c = a_inv * b * a_inv;
  if (!c.allFinite()) return INFINITY;
  if (criterion == DesignCriterion::kA) return c.trace();
  const Eigen::LLT<Eigen::MatrixXd> llt(0.5 * (c + c.transpose()));
  if (llt.info() != Eigen::Success) return INFINITY;
  return 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
}

double SetCriterion(const std::vector<PlannedView>& candidates, const std::vector<size_t>& set,
                    const PlanOptions& o) {
  std::vector<const PlannedView*> views;
  for (size_t i : set) views.push_back(&candidates[i]);
  return Criterion(SumInformation(views, o), o.criterion);
}

// Greedy: add the candidate that lowers the criterion most, N times. The first choices are made
// while the information is still singular; exchanges then swap a chosen pose for an unchosen
// one while that lowers the criterion (Fedorov's exchange algorithm).
std::vector<size_t> SelectViews(const std::vector<PlannedView>& candidates, const PlanOptions& o) {
  std::vector<size_t> set;
  std::vector<bool> chosen(candidates.size(), false);
  for (int step = 0; step < o.views; ++step) {
    double best = INFINITY;
    size_t best_i = candidates.size();
    for (size_t i = 0; i < candidates.size(); ++i) {
      if (chosen[i]) continue;
      set.push_back(i);
      const double f = SetCriterion(candidates, set, o);
      set.pop_back();
      if (f < best || best_i == candidates.size()) {
        best = f;
        best_i = i;
      }
    }
    set.push_back(best_i);
    chosen[best_i] = true;
  }
  double current = SetCriterion(candidates, set, o);
  for (int pass = 0; pass < 20; ++pass) {
    bool improved = false;
    for (size_t s = 0; s < set.size(); ++s) {
      for (size_t i = 0; i < candidates.size(); ++i) {
        if (chosen[i]) continue;
        const size_t old = set[s];
        set[s] = i;
        const double f = SetCriterion(candidates, set, o);
        if (f < current - 1e-9 * std::abs(current)) {
          current = f;
          chosen[old] = false;
          chosen[i] = true;
          improved = true;
        } else {
          set[s] = old;
        }
      }
    }
    if (!improved) break;
  }
  return set;
}

}  // namespace

PredictedUncertainty PredictViews(const std::vector<PlannedView>& views, const PlanOptions& o) {
  std::vector<const PlannedView*> ptr;
  for (const auto& v : views) ptr.push_back(&v);
  return PredictUncertainty(SumInformation(ptr, o), o.fit);
}

std::vector<Rigid3d> DefaultOrbit(const Board& board, int count) {
  synth::Scene scene;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (const auto& p : board.Points()) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if (!board.Points().empty()) scene.views.target = 0.5 * (lo + hi);
  const int rings = static_cast<int>(scene.views.rings_deg.size());
  scene.views.per_ring = std::max(1, (count + rings - 1) / rings);
  const std::vector<Rigid3d> all = scene.CamFromBoardPoses();
  std::vector<Rigid3d> out;
  for (int i = 0; i < count; ++i) out.push_back(all[i * all.size() / count]);
  return out;
}

namespace {

// Poses on the candidate grid that see the board, with their predicted information.
std::vector<PlannedView> Candidates(const Board& board, const CameraModel& camera,
                                    const PlanOptions& o) {
  const Eigen::Vector3d target = Centroid(board.sample_region());
  std::vector<Rigid3d> poses;
  for (double d : o.distances_m) {
    for (double polar : o.polar_deg) {
      synth::Scene ring;
      ring.views.target = target;
      ring.views.distance = d;
      ring.views.rings_deg = {polar};
      ring.views.per_ring = polar == 0 ? 1 : o.azimuths;
      ring.views.roll_deg = 0;
      for (const Rigid3d& pose : ring.CamFromBoardPoses()) {
        const Eigen::Vector3d centre = pose.Inverse().t;
        if (o.hypothesis.lamp_frame == LampFrame::kBoard &&
            (centre - o.hypothesis.lamp).norm() < o.min_lamp_clearance_m) {
          continue;
        }
        if (Reachable(pose, camera, board)) poses.push_back(pose);
      }
    }
  }
  std::vector<PlannedView> views(poses.size());
  ParallelFor(poses.size(), o.fit.threads, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) views[i] = PredictView(poses[i], camera, board, o);
  });
  std::vector<PlannedView> usable;
  for (auto& v : views) {
    if (!v.information.names.empty()) usable.push_back(std::move(v));
  }
  return usable;
}

}  // namespace

PlanResult MakePlan(const Board& board, const CameraModel& camera, const PlanOptions& options) {
  options.Check();
  if (board.sample_region().size() < 3) {
    throw InputError("--board: the board file has no sample_region: nothing to plan for");
  }
  PlanResult r;
  r.options = options;
  const std::vector<PlannedView> candidates = Candidates(board, camera, options);
  r.candidates = candidates.size();
  if (candidates.size() < static_cast<size_t>(options.views)) {
    throw InputError(fmt::format(
        "--views {}: only {} candidate poses see every tag and the sample unsaturated (camera "
        "too narrow for --distances, or the exposure saturates the sample)",
        options.views, candidates.size()));
  }
  spdlog::info("plan: {} reachable candidate poses", candidates.size());
  const std::vector<size_t> chosen = SelectViews(candidates, options);
  for (size_t i : chosen) r.plan.push_back(candidates[i]);
  // Capture order: by distance, then polar angle, then azimuth (fewer tripod moves).
  std::sort(r.plan.begin(), r.plan.end(), [](const PlannedView& a, const PlannedView& b) {
    return std::tie(a.distance_m, a.polar_deg, a.azimuth_deg) <
           std::tie(b.distance_m, b.polar_deg, b.azimuth_deg);
  });
  for (const Rigid3d& pose : DefaultOrbit(board, options.views)) {
    r.orbit.push_back(PredictView(pose, camera, board, options));
  }
  r.plan_prediction = PredictViews(r.plan, options);
  r.orbit_prediction = PredictViews(r.orbit, options);
  std::vector<size_t> all_plan(r.plan.size()), all_orbit(r.orbit.size());
  for (size_t i = 0; i < all_plan.size(); ++i) all_plan[i] = i;
  for (size_t i = 0; i < all_orbit.size(); ++i) all_orbit[i] = i;
  r.plan_criterion = SetCriterion(r.plan, all_plan, options);
  r.orbit_criterion = SetCriterion(r.orbit, all_orbit, options);
  return r;
}

}  // namespace gonio
