// The Ceres problem of the joint fit (estimation/joint/joint_fit.h), internal to joint_fit.cc: the
// lamp and viewing geometry of an observation, the residuals of sample and white-reference
// observations, the unknowns (State), building and solving the problem, and the radiance a
// state predicts.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <spdlog/spdlog.h>
#include <Eigen/Eigenvalues>

#include "common/math.h"
#include "common/parallel.h"
#include "estimation/joint/joint_fit.h"
#include "reflectance/angles.h"
#include "reflectance/model.h"

namespace gonio::joint_fit_internal {

// A fitted sample-height correction is searched within this many metres of board.json's.
inline constexpr double kMaxSampleHeightOffset = 0.05;

// Lamp position in the board frame for one observation: `lamp` as fitted, in the board frame,
// or in the camera frame (then moved by the observation's board_from_cam pose).
template <typename T>
void LampInBoard(const Observation& o, LampFrame frame, const T* lamp, T* lamp_in_board) {
  if (frame == LampFrame::kBoard) {
    for (int k = 0; k < 3; ++k) lamp_in_board[k] = lamp[k];
    return;
  }
  const T aa[3] = {T(o.board_from_cam_aa.x()), T(o.board_from_cam_aa.y()),
                   T(o.board_from_cam_aa.z())};
  ceres::AngleAxisRotatePoint(aa, lamp, lamp_in_board);
  for (int k = 0; k < 3; ++k) lamp_in_board[k] += T(o.camera_in_board[k]);
}

// Irradiance factor cos(theta_i)/d^2 at the observed point for the lamp at `lamp_in_board`,
// and the (unnormalized) directions to lamp and camera in the sample frame (board x, -y, -z:
// the sample's outward normal is -z_board). Call sites name them lb, ls and vs.
// height_offset: the sample's surface this much further out of the board than the
// observation's point (metres; the fitted correction to board.json's sample_height_m): the
// point moves along the pixel's ray, from the camera, to the plane z = p.z - height_offset.
// in_plane: a point of the observation's patch this far (board x, y, metres) from its centre.
template <typename T>
T Geometry(const Observation& o, const T* lamp_in_board, T* lamp_dir_in_sample,
           T* view_dir_in_sample, const T& height_offset = T(0),
           const Eigen::Vector2d& in_plane = Eigen::Vector2d::Zero()) {
  const T* lb = lamp_in_board;
  T* ls = lamp_dir_in_sample;
  T* vs = view_dir_in_sample;
  const Eigen::Vector3d& c = o.camera_in_board;
  const Eigen::Vector3d ray = o.p_in_board - c;
  const T along = (T(ray.z()) - height_offset) / T(ray.z());  // 1 without an offset
  const T p[3] = {T(c.x()) + along * T(ray.x()) + T(in_plane.x()),
                  T(c.y()) + along * T(ray.y()) + T(in_plane.y()), T(c.z()) + along * T(ray.z())};
  const T l[3] = {lb[0] - p[0], lb[1] - p[1], lb[2] - p[2]};
  ls[0] = l[0];
  ls[1] = -l[1];
  ls[2] = -l[2];
  vs[0] = T(c.x()) - p[0];
  vs[1] = -(T(c.y()) - p[1]);
  vs[2] = -(T(c.z()) - p[2]);
  const T d2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
  using std::sqrt;
  return ls[2] / (d2 * sqrt(d2));  // cos(theta_i) / d^2
}

// The points a patch's mean radiance is evaluated at (PatchModel::kAverage): with the patch
// area's second moment S = sum_k lambda_k e_k e_k' (Observation::patch_moment), the four points
// +-sqrt(2 lambda_k) e_k, equally weighted, have mean 0 and second moment S, so their mean is
// the area's mean for any radiance quadratic across the patch (the patch is a few pixels: its
// cubic terms are smaller by its width over the lobe's). None for kCentre or a one-pixel patch.
struct PatchPoints {
  int n = 0;
  std::array<Eigen::Vector2d, 4> offset;
};
inline PatchPoints PatchPointsOf(const Observation& o, bool average) {
  PatchPoints pts;
  if (!average || !(o.patch_moment.trace() > 0)) return pts;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(o.patch_moment);
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector2d a =
        std::sqrt(2.0 * std::max(0.0, eig.eigenvalues()(k))) * eig.eigenvectors().col(k);
    pts.offset[pts.n++] = a;
    pts.offset[pts.n++] = -a;
  }
  return pts;
}

// The lamp's radiance off the sample at an observation (no ambient): f_r I cos(theta_i) / d^2
// at the patch centre, or its mean over `pts`. p: the model's parameters of this channel.
template <typename M, typename T>
T LampRadiance(const Observation& o, const T* lamp_in_board, const T* p, const T& intensity,
               const T& height_offset, const PatchPoints& pts) {
  auto at = [&](const Eigen::Vector2d& in_plane) {
    T ls[3], vs[3];
    const T e = Geometry(o, lamp_in_board, ls, vs, height_offset, in_plane);
    if (!(ls[2] > T(0)) || !(e > T(0))) return T(0);
    return M::Evaluate(p, AnglesFromDirections(ls, vs)) * intensity * e;
  };
  if (pts.n == 0) return at(Eigen::Vector2d::Zero());
  T sum = T(0);
  for (int k = 0; k < pts.n; ++k) sum += at(pts.offset[k]);
  return sum / T(pts.n);
}

// Residual of one sample observation in one channel. The model's parameters come from two
// blocks: `shared` (roughness and the like, one for all channels) and `channel` (the
// per-channel ones of this channel); per_channel[k] says which block holds parameter k.
template <typename M>
struct SampleRadianceResidual {
  const Observation* o;
  int channel;
  double inv_sigma;
  LampFrame lamp_frame;
  std::array<bool, 16> per_channel;
  PatchPoints patch;
  // ambient: this channel's ambient radiance of the sample (0 and constant unless fitted).
  // height_offset: the fitted correction to the sample's height (0 and constant unless fitted).
  template <typename T>
  bool operator()(const T* shared, const T* chan, const T* lamp, const T* intensity,
                  const T* ambient, const T* height_offset, T* r) const {
    T lb[3];
    LampInBoard(*o, lamp_frame, lamp, lb);
    T p[M::kNumParams];
    for (int k = 0; k < M::kNumParams; ++k) p[k] = per_channel[k] ? chan[k] : shared[k];
    const T model = LampRadiance<M>(*o, lb, p, intensity[0], height_offset[0], patch) + ambient[0];
    r[0] = (model - T(o->radiance[channel])) * T(inv_sigma);
    return true;
  }
};

struct WhiteRadianceResidual {
  const Observation* o;
  int channel;
  double inv_sigma, white_albedo;
  LampFrame lamp_frame;
  // ambient_irradiance: this channel's ambient irradiance E_a (0 and constant unless fitted);
  // the Lambertian reference reflects A_w / pi of it.
  template <typename T>
  bool operator()(const T* lamp, const T* intensity, const T* ambient_irradiance, T* r) const {
    T lb[3], ls[3], vs[3];
    LampInBoard(*o, lamp_frame, lamp, lb);
    const T e = Geometry(*o, lb, ls, vs);
    const T model =
        T(white_albedo * kInvPi) * ((e > T(0) ? intensity[0] * e : T(0)) + ambient_irradiance[0]);
    r[0] = (model - T(o->radiance[channel])) * T(inv_sigma);
    return true;
  }
};

inline double Sigma(const Observation& o, int c, double floor) {
  return std::sqrt(o.variance[c] + floor * floor * o.radiance[c] * o.radiance[c]) + 1e-30;
}

// A white-reference observation has a residual only when the reference's albedo is known.
inline bool HasResidual(const Observation& o, const JointFitOptions& options) {
  return !o.white || options.white_albedo.has_value();
}

// Residuals of the problem over `use`: one per channel of every observation that has one.
inline size_t CountResiduals(const ObservationSet& data, const std::vector<size_t>& use,
                             const JointFitOptions& options) {
  size_t n = 0;
  for (size_t i : use) n += HasResidual(data.observations[i], options) ? data.channels : 0;
  return n;
}

inline ceres::LossFunction* NewLoss(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(3.0);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(3.0);
    case RobustLoss::kNone:
      break;
  }
  return nullptr;
}

// The unknowns of one model's fit. `shared` and every `chan[c]` are full parameter vectors;
// only the shared entries of `shared` and the per-channel entries of `chan[c]` are free.
struct State {
  std::vector<double> shared;
  std::vector<std::vector<double>> chan;  // per channel (one when options.per_channel is off)
  Eigen::Vector3d lamp;
  double intensity = 1;
  // Per channel: the sample's ambient radiance and the ambient irradiance on the white
  // reference (docs/pipeline.md "Ambient light"); zero and held constant unless fitted.
  std::vector<double> ambient_sample, ambient_irradiance;
  double height_offset = 0;  // metres, added to board.json's sample height when fitted
  double cost = INFINITY;
  bool usable = false;
  bool stopped_early = false;  // SearchStop ended the solve (a candidate that cannot win)
};

// Stopping a candidate that cannot win (docs/pipeline.md "Staged search"). A search candidate
// is selected only if its criterion beats every earlier stage's fit; those have no more
// parameters, so it needs a weighted sum of squares below the lowest of theirs (`to_beat`).
// Its robust cost C is at most half its sum of squares (Huber, Cauchy and soft-L1 all have
// rho(s) <= s), so a solve whose cost, shrinking at the fastest rate of its last kWindow
// successful steps for every iteration it has left, stays above to_beat / 2 cannot reach it: it
// is stopped there. A solve's rate of descent falls as it nears its minimum, so the projection
// is generous (and the bound loose where residuals are large, C well below half the squares);
// the iteration limit would end such a solve anyway.
class SearchStop : public ceres::IterationCallback {
 public:
  SearchStop(double to_beat, int max_iterations) : to_beat_(to_beat), max_(max_iterations) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& it) override {
    const double before = it.cost + it.cost_change;
    if (it.iteration == 0 || !it.step_is_successful || !(before > 0)) {
      return ceres::SOLVER_CONTINUE;
    }
    rates_[successful_++ % kWindow] = std::clamp(it.cost_change / before, 0.0, 1.0);
    if (successful_ < kWindow) return ceres::SOLVER_CONTINUE;
    const double rate = *std::max_element(rates_.begin(), rates_.end());
    const double left = std::max(0, max_ - it.iteration);
    if (2.0 * it.cost * std::pow(1.0 - rate, left) <= to_beat_) return ceres::SOLVER_CONTINUE;
    stopped_ = true;
    return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }
  bool stopped() const { return stopped_; }

 private:
  static constexpr int kWindow = 5;
  double to_beat_;
  int max_;
  std::array<double, kWindow> rates_{};
  int successful_ = 0;
  bool stopped_ = false;
};

template <typename M>
void AddResiduals(const ObservationSet& data, const std::vector<size_t>& use, const ModelInfo& info,
                  const JointFitOptions& o, State* s, bool plain, ceres::Problem* problem) {
  std::array<bool, 16> per_channel{};
  for (int k = 0; k < M::kNumParams; ++k) per_channel[k] = info.params[k].per_channel;
  const bool average = o.patch_model == PatchModel::kAverage;
  for (size_t idx : use) {
    const Observation& obs = data.observations[idx];
    if (!HasResidual(obs, o)) continue;
    const PatchPoints patch = PatchPointsOf(obs, average);  // the same in every channel
    for (int c = 0; c < data.channels; ++c) {
      const int chan = o.per_channel ? c : 0;
      ceres::LossFunction* loss = plain ? nullptr : NewLoss(o.robust_loss);
      const double inv_sigma = 1.0 / Sigma(obs, c, o.relative_noise_floor);
      if (obs.white) {
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<WhiteRadianceResidual, 1, 3, 1, 1>(
                new WhiteRadianceResidual{&obs, c, inv_sigma, *o.white_albedo, o.lamp_frame}),
            loss, s->lamp.data(), &s->intensity, &s->ambient_irradiance[c]);
      } else {
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<SampleRadianceResidual<M>, 1, M::kNumParams,
                                            M::kNumParams, 3, 1, 1, 1>(
                new SampleRadianceResidual<M>{&obs, c, inv_sigma, o.lamp_frame, per_channel,
                                              patch}),
            loss, s->shared.data(), s->chan[chan].data(), s->lamp.data(), &s->intensity,
            &s->ambient_sample[c], &s->height_offset);
      }
    }
  }
}

// The ambient terms (held at zero) and the sample-height correction are parameters only when
// the options fit them; otherwise constant, in the solved and in the plain problem alike, so
// neither the solve nor the uncertainty analysis sees them.
inline void HoldUnfittedTerms(const JointFitOptions& o, State* s, ceres::Problem* problem) {
  std::vector<double*> held;
  if (o.ambient != AmbientTerm::kFit) {
    for (double& a : s->ambient_sample) held.push_back(&a);
    for (double& a : s->ambient_irradiance) held.push_back(&a);
  }
  if (o.sample_height != NuisanceTerm::kFit) held.push_back(&s->height_offset);
  for (double* b : held) {
    if (problem->HasParameterBlock(b)) problem->SetParameterBlockConstant(b);
  }
}

// Registry bounds on every parameter, the intensity positive, the height correction bounded
// when fitted, and manifolds that hold the entries of each block that belong to the other
// block constant.
inline void ConstrainParameters(const ModelInfo& info, const JointFitOptions& o, State* s,
                                ceres::Problem* problem) {
  if (o.sample_height == NuisanceTerm::kFit && problem->HasParameterBlock(&s->height_offset)) {
    // The sample's top stays in front of the board's far side and within a sane thickness.
    problem->SetParameterLowerBound(&s->height_offset, 0, -kMaxSampleHeightOffset);
    problem->SetParameterUpperBound(&s->height_offset, 0, kMaxSampleHeightOffset);
  }
  const int n = info.num_params();
  std::vector<int> channel_idx, shared_idx;
  for (int k = 0; k < n; ++k) (info.params[k].per_channel ? channel_idx : shared_idx).push_back(k);
  if (problem->HasParameterBlock(s->shared.data())) {
    if (shared_idx.empty()) {
      problem->SetParameterBlockConstant(s->shared.data());
    } else if (!channel_idx.empty()) {
      problem->SetManifold(s->shared.data(), new ceres::SubsetManifold(n, channel_idx));
    }
    for (auto& ch : s->chan) {
      if (!problem->HasParameterBlock(ch.data())) continue;
      if (channel_idx.empty()) {
        problem->SetParameterBlockConstant(ch.data());
      } else if (!shared_idx.empty()) {
        problem->SetManifold(ch.data(), new ceres::SubsetManifold(n, shared_idx));
      }
    }
    for (int k = 0; k < n; ++k) {
      problem->SetParameterLowerBound(s->shared.data(), k, info.params[k].min);
      problem->SetParameterUpperBound(s->shared.data(), k, info.params[k].max);
      for (auto& ch : s->chan) {
        if (!problem->HasParameterBlock(ch.data())) continue;
        problem->SetParameterLowerBound(ch.data(), k, info.params[k].min);
        problem->SetParameterUpperBound(ch.data(), k, info.params[k].max);
      }
    }
  }
  if (problem->HasParameterBlock(&s->intensity)) {
    problem->SetParameterLowerBound(&s->intensity, 0, 1e-12 * std::abs(s->intensity));
  }
}

// Builds the problem over `use` observations. `plain` leaves out loss, bounds and manifolds
// (for the Jacobian of the uncertainty analysis).
template <typename M>
void BuildProblem(const ObservationSet& data, const std::vector<size_t>& use, const ModelInfo& info,
                  const JointFitOptions& o, State* s, bool plain, ceres::Problem* problem) {
  AddResiduals<M>(data, use, info, o, s, plain, problem);
  HoldUnfittedTerms(o, s, problem);
  if (!plain) ConstrainParameters(info, o, s, problem);
}

template <typename M>
void Solve(const ObservationSet& data, const std::vector<size_t>& use, const ModelInfo& info,
           const JointFitOptions& o, State* s) {
  ceres::Problem problem;
  BuildProblem<M>(data, use, info, o, s, false, &problem);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = o.function_tolerance;
  so.logging_type = ceres::SILENT;
  // The bounds make Ceres' trust-region minimizer run a projected Armijo line search along
  // every step. With its default cubic interpolation that search evaluates the gradient, i.e.
  // the whole Jacobian, at the trial point: a second Jacobian per iteration, about 40% of a
  // fit's time (counted with Solver::Summary, docs/bench.md). Quadratic interpolation needs
  // only the trial point's cost (the gradient at the start is known); a step that passes the
  // Armijo test at full length, as almost every step does, is the same either way.
  so.line_search_interpolation_type = ceres::QUADRATIC;
  so.num_threads = ResolveThreads(o.threads);
  SearchStop stop(o.search_weighted_ssr_to_beat, o.max_iterations);
  if (std::isfinite(o.search_weighted_ssr_to_beat)) so.callbacks.push_back(&stop);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  s->stopped_early = stop.stopped();
  spdlog::debug("{}: {} iterations, {} residual blocks, cost {:.6g} -> {:.6g}, {:.3f} s", info.name,
                summary.iterations.size(), summary.num_residual_blocks, summary.initial_cost,
                summary.final_cost, summary.total_time_in_seconds);
  s->cost = summary.final_cost;
  s->usable = summary.IsSolutionUsable() && std::isfinite(summary.final_cost) &&
              s->lamp.allFinite() && std::isfinite(s->intensity);
}

// The radiance `s` predicts for an observation's channel, with the patch modelled as
// `patch_model` says (kAverage: the mean over the patch; otherwise its centre).
template <typename M>
double Predict(const Observation& obs, int c, const State& s, const ModelInfo& info,
               LampFrame lamp_frame, std::optional<double> white_albedo,
               PatchModel patch_model = PatchModel::kCentre) {
  double lb[3], ls[3], vs[3];
  LampInBoard(obs, lamp_frame, s.lamp.data(), lb);
  if (obs.white) {
    const double e = Geometry(obs, lb, ls, vs);
    return white_albedo.value_or(0.0) * kInvPi *
           ((e > 0 ? s.intensity * e : 0.0) + s.ambient_irradiance[c]);
  }
  double p[M::kNumParams];
  const auto& ch = s.chan[std::min<size_t>(c, s.chan.size() - 1)];
  for (int k = 0; k < M::kNumParams; ++k) p[k] = info.params[k].per_channel ? ch[k] : s.shared[k];
  return LampRadiance<M>(obs, lb, p, s.intensity, s.height_offset,
                         PatchPointsOf(obs, patch_model == PatchModel::kAverage)) +
         s.ambient_sample[c];
}

// One free column of the Jacobian: the entry `index` of parameter block `block`, its range
// (the scale of AnalyzeUncertainty's range-scaled Jacobian) and the name it is reported by.
struct FreeColumn {
  double* block;
  int index;
  double range;
  std::string name;
};

// The free columns of `s`'s problem: shared, then per-channel parameters (channel c > 0 named
// "albedo[c]"), lamp x, y, z (range: its distance) and intensity. `blocks` receives the
// parameter blocks in evaluation order.
std::vector<FreeColumn> FreeColumns(const ModelInfo& info, const ceres::Problem& problem, State* s,
                                    double lamp_distance, std::vector<double*>* blocks);

// The Jacobian of the problem's residuals restricted to `cols` (one row per residual, in the
// order they were added); `cost` is half the sum of squared residuals.
Eigen::MatrixXd FreeJacobian(ceres::Problem* problem, const std::vector<double*>& blocks,
                             const std::vector<FreeColumn>& cols, double* cost);

// Every `max_n`-th observation or so: a deterministic subsample of at most max_n.
std::vector<size_t> Subsample(const ObservationSet& data, size_t max_n);

// One registry model fitted jointly with the lamp (joint_fit.cc), for the model search
// (joint_selection.cc): from the registry defaults and `lamp_start`, or from `warm`, a
// converged fit of the same model (on other observations of the same scene, or without some of
// the nuisance terms `options` fits, which then start at zero), so a refit does not descend
// again from the defaults.
JointFitResult FitCandidate(const std::string& model, const ObservationSet& data,
                            const std::vector<size_t>& use, const Eigen::Vector3d& lamp_start,
                            const JointFitOptions& options, bool cross_validate,
                            const JointFitResult* warm = nullptr);

}  // namespace gonio::joint_fit_internal
