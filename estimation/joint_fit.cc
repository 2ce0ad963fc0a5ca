#include "estimation/joint_fit.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <set>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"
#include "common/stats.h"
#include "estimation/option_words.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

constexpr OptionWord<LightFrame> kLightFrameWords[] = {{LightFrame::kBoard, "board"},
                                                       {LightFrame::kCamera, "camera"}};

// Lamp position in the board frame for one observation: `light` as fitted, in the board frame,
// or in the camera frame (then moved by the observation's board_from_cam pose).
template <typename T>
void LightInBoard(const Observation& o, LightFrame frame, const T* light, T* light_in_board) {
  if (frame == LightFrame::kBoard) {
    for (int k = 0; k < 3; ++k) light_in_board[k] = light[k];
    return;
  }
  const T aa[3] = {T(o.board_from_cam_aa.x()), T(o.board_from_cam_aa.y()),
                   T(o.board_from_cam_aa.z())};
  ceres::AngleAxisRotatePoint(aa, light, light_in_board);
  for (int k = 0; k < 3; ++k) light_in_board[k] += T(o.camera_in_board[k]);
}

// Irradiance factor cos(theta_i)/d^2 at the observed point for the lamp at `light_in_board`,
// and the (unnormalized) directions to lamp and camera in the sample frame (board x, -y, -z:
// the sample's outward normal is -z_board). Call sites name them lb, ls and vs.
template <typename T>
T Geometry(const Observation& o, const T* light_in_board, T* light_dir_in_sample,
           T* view_dir_in_sample) {
  const T* lb = light_in_board;
  T* ls = light_dir_in_sample;
  T* vs = view_dir_in_sample;
  const T l[3] = {lb[0] - T(o.p_in_board.x()), lb[1] - T(o.p_in_board.y()),
                  lb[2] - T(o.p_in_board.z())};
  ls[0] = l[0];
  ls[1] = -l[1];
  ls[2] = -l[2];
  const Eigen::Vector3d v = o.camera_in_board - o.p_in_board;
  vs[0] = T(v.x());
  vs[1] = T(-v.y());
  vs[2] = T(-v.z());
  const T d2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
  using std::sqrt;
  return ls[2] / (d2 * sqrt(d2));  // cos(theta_i) / d^2
}

// Residual of one sample observation in one channel. The model's parameters come from two
// blocks: `shared` (roughness and the like, one for all channels) and `channel` (the
// per-channel ones of this channel); per_channel[k] says which block holds parameter k.
template <typename M>
struct SampleRadianceResidual {
  const Observation* o;
  int channel;
  double inv_sigma;
  LightFrame light_frame;
  std::array<bool, 16> per_channel;
  template <typename T>
  bool operator()(const T* shared, const T* chan, const T* light, const T* intensity, T* r) const {
    T lb[3], ls[3], vs[3];
    LightInBoard(*o, light_frame, light, lb);
    const T e = Geometry(*o, lb, ls, vs);
    T p[M::kNumParams];
    for (int k = 0; k < M::kNumParams; ++k) p[k] = per_channel[k] ? chan[k] : shared[k];
    T f = T(0);
    if (ls[2] > T(0)) f = M::Evaluate(p, AnglesFromDirections(ls, vs));
    const T model = e > T(0) ? f * intensity[0] * e : T(0);
    r[0] = (model - T(o->radiance[channel])) * T(inv_sigma);
    return true;
  }
};

struct WhiteRadianceResidual {
  const Observation* o;
  int channel;
  double inv_sigma, white_albedo;
  LightFrame light_frame;
  template <typename T>
  bool operator()(const T* light, const T* intensity, T* r) const {
    T lb[3], ls[3], vs[3];
    LightInBoard(*o, light_frame, light, lb);
    const T e = Geometry(*o, lb, ls, vs);
    const T model = e > T(0) ? T(white_albedo * kInvPi) * intensity[0] * e : T(0);
    r[0] = (model - T(o->radiance[channel])) * T(inv_sigma);
    return true;
  }
};

double Sigma(const Observation& o, int c, double floor) {
  return std::sqrt(o.variance[c] + floor * floor * o.radiance[c] * o.radiance[c]) + 1e-30;
}

// A white-reference observation has a residual only when the reference's albedo is known.
bool HasResidual(const Observation& o, const JointFitOptions& options) {
  return !o.white || options.white_albedo.has_value();
}

// Residuals of the problem over `use`: one per channel of every observation that has one.
size_t CountResiduals(const ObservationSet& data, const std::vector<size_t>& use,
                      const JointFitOptions& options) {
  size_t n = 0;
  for (size_t i : use) n += HasResidual(data.observations[i], options) ? data.channels : 0;
  return n;
}

ceres::LossFunction* NewLoss(RobustLoss loss) {
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
  Eigen::Vector3d light;
  double intensity = 1;
  double cost = INFINITY;
  bool usable = false;
};

template <typename M>
void AddResiduals(const ObservationSet& data, const std::vector<size_t>& use, const ModelInfo& info,
                  const JointFitOptions& o, State* s, bool plain, ceres::Problem* problem) {
  std::array<bool, 16> per_channel{};
  for (int k = 0; k < M::kNumParams; ++k) per_channel[k] = info.params[k].per_channel;
  for (size_t idx : use) {
    const Observation& obs = data.observations[idx];
    if (!HasResidual(obs, o)) continue;
    for (int c = 0; c < data.channels; ++c) {
      const int chan = o.per_channel ? c : 0;
      ceres::LossFunction* loss = plain ? nullptr : NewLoss(o.robust_loss);
      const double inv_sigma = 1.0 / Sigma(obs, c, o.relative_noise_floor);
      if (obs.white) {
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<WhiteRadianceResidual, 1, 3, 1>(
                new WhiteRadianceResidual{&obs, c, inv_sigma, *o.white_albedo, o.light_frame}),
            loss, s->light.data(), &s->intensity);
      } else {
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<SampleRadianceResidual<M>, 1, M::kNumParams,
                                            M::kNumParams, 3, 1>(
                new SampleRadianceResidual<M>{&obs, c, inv_sigma, o.light_frame, per_channel}),
            loss, s->shared.data(), s->chan[chan].data(), s->light.data(), &s->intensity);
      }
    }
  }
}

// Registry bounds on every parameter, the intensity positive, and manifolds that hold the
// entries of each block that belong to the other block constant.
void ConstrainParameters(const ModelInfo& info, State* s, ceres::Problem* problem) {
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
  if (!plain) ConstrainParameters(info, s, problem);
}

template <typename M>
void Solve(const ObservationSet& data, const std::vector<size_t>& use, const ModelInfo& info,
           const JointFitOptions& o, State* s) {
  ceres::Problem problem;
  BuildProblem<M>(data, use, info, o, s, false, &problem);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-10;
  so.logging_type = ceres::SILENT;
  so.num_threads = ResolveThreads(o.threads);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  s->cost = summary.final_cost;
  s->usable = summary.IsSolutionUsable() && std::isfinite(summary.final_cost) &&
              s->light.allFinite() && std::isfinite(s->intensity);
}

template <typename M>
double Predict(const Observation& obs, int c, const State& s, const ModelInfo& info,
               LightFrame light_frame, std::optional<double> white_albedo) {
  double lb[3], ls[3], vs[3];
  LightInBoard(obs, light_frame, s.light.data(), lb);
  const double e = Geometry(obs, lb, ls, vs);
  if (e <= 0) return 0.0;
  if (obs.white) return white_albedo.value_or(0.0) * kInvPi * s.intensity * e;
  double p[M::kNumParams];
  const auto& ch = s.chan[std::min<size_t>(c, s.chan.size() - 1)];
  for (int k = 0; k < M::kNumParams; ++k) p[k] = info.params[k].per_channel ? ch[k] : s.shared[k];
  return M::Evaluate(p, AnglesFromDirections(ls, vs)) * s.intensity * e;
}

std::vector<size_t> Subsample(const ObservationSet& data, size_t max_n) {
  std::vector<size_t> idx;
  const size_t n = data.observations.size();
  const size_t stride = std::max<size_t>(1, (n + max_n - 1) / std::max<size_t>(max_n, 1));
  for (size_t i = 0; i < n; i += stride) idx.push_back(i);
  return idx;
}

// Start values: the registry defaults, the given lamp, and the intensity that best scales the
// default model onto the data (weighted least squares).
template <typename M>
State InitialState(const ModelInfo& info, const ObservationSet& data,
                   const std::vector<size_t>& use, const Eigen::Vector3d& light_start,
                   const JointFitOptions& o) {
  State s;
  for (const auto& p : info.params) s.shared.push_back(p.default_value);
  s.chan.assign(o.per_channel ? data.channels : 1, s.shared);
  s.light = light_start;
  s.intensity = 1.0;
  double fy = 0, ff = 0;
  for (size_t i : use) {
    const Observation& obs = data.observations[i];
    for (int c = 0; c < data.channels; ++c) {
      const double pred = Predict<M>(obs, c, s, info, o.light_frame, o.white_albedo);
      const double w = 1.0 / std::pow(Sigma(obs, c, o.relative_noise_floor), 2);
      fy += w * pred * obs.radiance[c];
      ff += w * pred * pred;
    }
  }
  s.intensity = ff > 0 && fy > 0 ? fy / ff : 1.0;
  return s;
}

// The result's parameters and lamp from a solved state, before the uncertainty analysis; a fit
// that did not converge has NaN parameters and no standard deviations.
JointFitResult ResultFromState(const ModelInfo& info, const State& s, const JointFitOptions& o,
                               size_t n_observations) {
  JointFitResult r;
  r.light_frame = o.light_frame;
  r.absolute = o.white_albedo.has_value();
  r.n_observations = n_observations;
  BrdfFitResult& m = r.material;
  m.model = info.name;
  for (const auto& p : info.params) m.param_names.push_back(p.name);
  if (!s.usable) {
    m.converged = false;
    m.message = "the joint fit did not converge";
    m.params.assign(info.num_params(), NAN);
    m.stddev.assign(info.num_params(), std::nullopt);
    return r;
  }
  m.converged = true;
  m.params = s.shared;
  for (int k = 0; k < info.num_params(); ++k) {
    if (info.params[k].per_channel) m.params[k] = s.chan[0][k];
  }
  r.light_position = s.light;
  r.intensity = s.intensity;
  for (const auto& p : info.params) {
    if (p.per_channel) r.per_channel_param_names.push_back(p.name);
  }
  for (const auto& ch : s.chan) {
    std::vector<double> v;
    for (int k = 0; k < info.num_params(); ++k) {
      if (info.params[k].per_channel) v.push_back(ch[k]);
    }
    r.per_channel_params.push_back(v);
  }
  return r;
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
                                    double light_distance, std::vector<double*>* blocks) {
  std::vector<FreeColumn> cols;
  if (problem.HasParameterBlock(s->shared.data())) {
    blocks->push_back(s->shared.data());
    for (int k = 0; k < info.num_params(); ++k) {
      const ParamInfo& p = info.params[k];
      if (!p.per_channel) cols.push_back({s->shared.data(), k, p.max - p.min, p.name});
    }
    for (size_t c = 0; c < s->chan.size(); ++c) {
      if (!problem.HasParameterBlock(s->chan[c].data())) continue;
      blocks->push_back(s->chan[c].data());
      for (int k = 0; k < info.num_params(); ++k) {
        const ParamInfo& p = info.params[k];
        if (!p.per_channel) continue;
        cols.push_back({s->chan[c].data(), k, p.max - p.min,
                        c == 0 ? p.name : fmt::format("{}[{}]", p.name, c)});
      }
    }
  }
  blocks->push_back(s->light.data());
  for (int k = 0; k < 3; ++k) {
    cols.push_back({s->light.data(), k, light_distance, std::string("light_") + "xyz"[k]});
  }
  blocks->push_back(&s->intensity);
  cols.push_back({&s->intensity, 0, std::abs(s->intensity), "intensity"});
  return cols;
}

// The Jacobian of the problem's residuals restricted to `cols`; `cost` is half the sum of
// squared residuals.
Eigen::MatrixXd FreeJacobian(ceres::Problem* problem, const std::vector<double*>& blocks,
                             const std::vector<FreeColumn>& cols, double* cost) {
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  ceres::CRSMatrix crs;
  problem->Evaluate(eo, cost, nullptr, nullptr, &crs);
  // Column offsets of each block in the evaluated Jacobian.
  std::map<double*, int> offset;
  int off = 0;
  for (double* b : blocks) {
    offset[b] = off;
    off += problem->ParameterBlockSize(b);
  }
  std::map<int, int> col_of;
  for (size_t j = 0; j < cols.size(); ++j) col_of[offset[cols[j].block] + cols[j].index] = j;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, cols.size());
  for (int row = 0; row < crs.num_rows; ++row) {
    for (int k = crs.rows[row]; k < crs.rows[row + 1]; ++k) {
      const auto it = col_of.find(crs.cols[k]);
      if (it != col_of.end()) J(row, it->second) = crs.values[k];
    }
  }
  return J;
}

// Standard deviations and undetermined directions into `r`: the lamp's, the intensity's and
// the material's (channel 0 stands for the per-channel parameters). `s` holds the blocks the
// columns point into.
void AssignUncertainty(const UncertaintyResult& u, const std::vector<FreeColumn>& cols,
                       const State& s, int num_params, JointFitResult* r) {
  BrdfFitResult& m = r->material;
  m.covariance = u.covariance;
  m.n_effective = u.rank;
  m.n_params = static_cast<int>(cols.size());
  m.stddev.assign(num_params, std::nullopt);
  Eigen::Vector3d light_sd;
  bool light_ok = true;
  for (size_t j = 0; j < cols.size(); ++j) {
    const FreeColumn& c = cols[j];
    if (c.block == s.light.data()) {
      light_ok = light_ok && u.stddev[j].has_value();
      light_sd[c.index] = u.stddev[j].value_or(NAN);
      if (u.undetermined[j]) r->undetermined_light.push_back(c.name);
    } else if (c.block == &s.intensity) {
      r->intensity_stddev = u.stddev[j];
      if (u.undetermined[j]) r->undetermined_light.push_back("intensity");
    } else if (c.block == s.shared.data() || c.block == s.chan[0].data()) {
      m.stddev[c.index] = u.stddev[j];
      if (u.undetermined[j]) m.undetermined.push_back(c.name);
    } else if (u.undetermined[j]) {
      m.undetermined.push_back(c.name);
    }
  }
  if (light_ok) r->light_stddev = light_sd;
}

// Uncertainty from the Jacobian of the plain residuals (no robust loss), free columns only
// (estimation/uncertainty.h).
template <typename M>
void AnalyzeJointUncertainty(const ModelInfo& info, const ObservationSet& data,
                             const std::vector<size_t>& use, const JointFitOptions& o,
                             const State& s, JointFitResult* r) {
  State plain = s;
  ceres::Problem problem;
  BuildProblem<M>(data, use, info, o, &plain, true, &problem);
  std::vector<double*> blocks;
  const double light_distance = (s.light - data.observations[use[0]].p_in_board).norm();
  const std::vector<FreeColumn> cols = FreeColumns(info, problem, &plain, light_distance, &blocks);
  double cost = 0;
  const Eigen::MatrixXd J = FreeJacobian(&problem, blocks, cols, &cost);
  std::vector<double> ranges;
  for (const auto& c : cols) ranges.push_back(c.range);
  const std::vector<bool> check_fraction(cols.size(), true);
  const UncertaintyResult u =
      AnalyzeUncertainty(J, ranges, 2 * cost, check_fraction, o.uncertainty);
  AssignUncertainty(u, cols, plain, info.num_params(), r);
}

// The lamp's distance is seen only through the change of cos(theta_i)/d^2 across the sample:
// below options.min_irradiance_contrast it is declared undetermined (joint_fit.h).
void CheckIrradianceContrast(const ObservationSet& data, const std::vector<size_t>& use,
                             const JointFitOptions& o, const State& s, JointFitResult* r) {
  double e_min = INFINITY, e_max = 0;
  for (size_t i : use) {
    const Observation& obs = data.observations[i];
    if (obs.white) continue;
    double lb[3], ls[3], vs[3];
    LightInBoard(obs, o.light_frame, s.light.data(), lb);
    const double e = Geometry(obs, lb, ls, vs);
    e_min = std::min(e_min, e);
    e_max = std::max(e_max, e);
  }
  const double contrast = e_min > 0 ? e_max / e_min - 1.0 : 0.0;
  if (contrast >= o.min_irradiance_contrast) return;
  r->light_stddev.reset();
  r->undetermined_light.push_back("light_distance");
  if (!r->absolute) r->undetermined_light.push_back("intensity");
  r->warnings.push_back(fmt::format(
      "the irradiance varies only {:.2f}% across the sample: the lamp's distance cannot be "
      "measured (only its direction); move the lamp closer",
      100 * contrast));
}

// Per-frame residuals into r->frames, and a warning for every frame whose mean relative
// residual exceeds max(5%, 4x the median frame's): a moved lamp or sample, a wrong exposure.
void FinishFrames(const ObservationSet& data, std::map<int, FrameResidual> frames,
                  JointFitResult* r) {
  std::vector<double> abs_means;
  for (auto& [f, fr] : frames) {
    fr.rms_sigma = std::sqrt(fr.rms_sigma / fr.n);
    fr.mean_relative /= fr.n;
    fr.file = f < static_cast<int>(data.frame_files.size()) ? data.frame_files[f] : "";
    abs_means.push_back(std::abs(fr.mean_relative));
    r->frames.push_back(fr);
  }
  if (abs_means.empty()) return;
  const double median = Median(abs_means);
  for (const auto& fr : r->frames) {
    if (std::abs(fr.mean_relative) > std::max(0.05, 4 * median)) {
      r->warnings.push_back(fmt::format(
          "frame {} ({}): the model is off by {:+.1f}% on average (median frame {:.1f}%): "
          "moved lamp or sample, or a wrong exposure?",
          fr.frame, fr.file, 100 * fr.mean_relative, 100 * median));
    }
  }
}

// Goodness of fit: the weighted sum of squares and AIC/BIC over every residual of the problem
// (a white-reference observation has one only with a known white albedo); rms, rel_rms and the
// per-frame residuals over the sample observations.
template <typename M>
void ComputeMetrics(const ModelInfo& info, const ObservationSet& data,
                    const std::vector<size_t>& use, const JointFitOptions& o, const State& s,
                    JointFitResult* r) {
  double ssr_w = 0, sq = 0, mean = 0;
  size_t n_res = 0, n = 0;
  std::map<int, FrameResidual> frames;
  for (size_t i : use) {
    const Observation& obs = data.observations[i];
    if (!HasResidual(obs, o)) continue;
    for (int c = 0; c < data.channels; ++c) {
      const double res =
          Predict<M>(obs, c, s, info, o.light_frame, o.white_albedo) - obs.radiance[c];
      const double z = res / Sigma(obs, c, o.relative_noise_floor);
      ssr_w += z * z;
      ++n_res;
      if (obs.white) continue;
      sq += res * res;
      mean += obs.radiance[c];
      ++n;
      auto& fr = frames[obs.frame];
      fr.frame = obs.frame;
      ++fr.n;
      fr.rms_sigma += z * z;
      fr.mean_relative += obs.radiance[c] > 0 ? res / obs.radiance[c] : 0.0;
    }
  }
  BrdfFitResult& m = r->material;
  const double nn = std::max<size_t>(n, 1);
  m.weighted_ssr = ssr_w;
  m.rms = std::sqrt(sq / nn);
  m.rel_rms = mean > 0 ? m.rms / (mean / nn) : m.rms;
  const double nr = static_cast<double>(std::max<size_t>(n_res, 1));
  m.aic = nr * std::log(std::max(ssr_w / nr, 1e-300)) + 2.0 * m.n_effective;
  m.bic = nr * std::log(std::max(ssr_w / nr, 1e-300)) + std::log(nr) * m.n_effective;
  FinishFrames(data, std::move(frames), r);
}

// RMS of the sample residuals of frames held out of the fit: K folds (frame q in fold q mod K),
// each refitted from the full-data state `s`. Nullopt with fewer than two frames.
template <typename M>
std::optional<double> HeldOutFrameRms(const ModelInfo& info, const ObservationSet& data,
                                      const std::vector<size_t>& use, const JointFitOptions& o,
                                      const State& s, const std::vector<FrameResidual>& frames) {
  std::vector<int> frame_ids;
  for (const auto& fr : frames) frame_ids.push_back(fr.frame);
  const int K = std::min<int>(o.cv_folds, static_cast<int>(frame_ids.size()));
  double cv_sq = 0;
  size_t cv_n = 0;
  for (int fold = 0; K >= 2 && fold < K; ++fold) {
    std::set<int> held;
    for (size_t q = 0; q < frame_ids.size(); ++q) {
      if (static_cast<int>(q % K) == fold) held.insert(frame_ids[q]);
    }
    std::vector<size_t> train, test;
    for (size_t i : use) (held.count(data.observations[i].frame) ? test : train).push_back(i);
    State t = s;
    Solve<M>(data, train, info, o, &t);
    if (!t.usable) t = s;
    for (size_t i : test) {
      const Observation& obs = data.observations[i];
      if (obs.white) continue;
      for (int c = 0; c < data.channels; ++c) {
        const double res =
            Predict<M>(obs, c, t, info, o.light_frame, o.white_albedo) - obs.radiance[c];
        cv_sq += res * res;
        ++cv_n;
      }
    }
  }
  if (cv_n == 0) return std::nullopt;
  return std::sqrt(cv_sq / cv_n);
}

// One model on the `use` observations from `light_start`: solve, uncertainty, the lamp
// distance's contrast check, metrics and (optionally) cross-validation over frames.
template <typename M>
JointFitResult FitModel(const ModelInfo& info, const ObservationSet& data,
                        const std::vector<size_t>& use, const Eigen::Vector3d& light_start,
                        const JointFitOptions& o, bool cross_validate) {
  State s = InitialState<M>(info, data, use, light_start, o);
  Solve<M>(data, use, info, o, &s);
  JointFitResult r = ResultFromState(info, s, o, use.size());
  r.material.n_samples = CountResiduals(data, use, o);
  if (!s.usable) return r;
  AnalyzeJointUncertainty<M>(info, data, use, o, s, &r);
  CheckIrradianceContrast(data, use, o, s, &r);
  ComputeMetrics<M>(info, data, use, o, s, &r);
  if (cross_validate) r.material.cv_rms = HeldOutFrameRms<M>(info, data, use, o, s, r.frames);
  return r;
}

}  // namespace

bool ObservationGeometry(const Observation& o, const JointFitResult& fit, Angles<double>* angles,
                         double* irradiance_factor) {
  double lb[3], ls[3], vs[3];
  LightInBoard(o, fit.light_frame, fit.light_position.data(), lb);
  *irradiance_factor = Geometry(o, lb, ls, vs);
  if (!(ls[2] > 0)) return false;
  *angles = AnglesFromDirections(ls, vs);
  return true;
}

LightFrame ParseLightFrame(const std::string& word, const std::string& option_name) {
  return ParseOptionWord(kLightFrameWords, word, option_name);
}

std::string ToString(LightFrame frame) { return OptionWordOf(kLightFrameWords, frame); }

void JointFitOptions::Check() const {
  if (white_albedo && !(*white_albedo > 0 && *white_albedo <= 1)) {
    throw InputError("--white-albedo must be in (0, 1]");
  }
  if (light_init && !light_init->allFinite()) throw InputError("--light-init must be finite");
  if (cv_folds < 2) throw InputError("cv folds must be >= 2");
  for (const auto& c : candidates) FindModel(c);
}

JointFitResult FitJoint(const std::string& model, const ObservationSet& data,
                        const Eigen::Vector3d& light_start, const JointFitOptions& options) {
  options.Check();
  std::vector<size_t> all(data.observations.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  JointFitResult r;
  const ModelInfo& info = FindModel(model);
  VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    r = FitModel<M>(info, data, all, light_start, options, true);
  });
  return r;
}

namespace {

// Deterministic lamp starts: near the camera for a lamp fixed in the camera frame; otherwise in
// front of the board (z < 0) at the median camera distance, on the sample's normal and on a
// 40-degree cone around it.
std::vector<Eigen::Vector3d> LightStarts(const ObservationSet& data, LightFrame frame) {
  std::vector<Eigen::Vector3d> starts;
  if (frame == LightFrame::kCamera) {
    for (const Eigen::Vector3d& d :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, 0, 0), Eigen::Vector3d(-0.1, 0, 0),
          Eigen::Vector3d(0, 0.1, 0), Eigen::Vector3d(0, -0.1, 0)}) {
      starts.push_back(d + Eigen::Vector3d(0, 0, 1e-3));
    }
    return starts;
  }
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  std::vector<double> dist;
  for (const auto& o : data.observations) {
    if (o.white) continue;
    centre += o.p_in_board;
    dist.push_back((o.camera_in_board - o.p_in_board).norm());
  }
  if (dist.empty()) throw InputError("no sample observations");
  centre /= static_cast<double>(dist.size());
  const double R = Median(dist);
  starts.push_back(centre + Eigen::Vector3d(0, 0, -R));
  for (int a = 0; a < 8; ++a) {
    const double az = a * kPi / 4, el = DegToRad(40);
    starts.push_back(centre + R * Eigen::Vector3d(std::sin(el) * std::cos(az),
                                                  std::sin(el) * std::sin(az), -std::cos(el)));
  }
  return starts;
}

}  // namespace

Eigen::Vector3d InitialLight(const ObservationSet& data, const JointFitOptions& options) {
  if (options.light_init) return *options.light_init;
  const std::vector<Eigen::Vector3d> starts = LightStarts(data, options.light_frame);
  JointFitOptions screen = options;
  screen.max_iterations = 50;
  const auto use = Subsample(data, 1500);
  const ModelInfo& info = FindModel("lambert");
  double best_cost = INFINITY;
  Eigen::Vector3d best = starts[0];
  for (const auto& start : starts) {
    const JointFitResult r = FitModel<Lambert>(info, data, use, start, screen, false);
    if (r.material.converged && r.material.weighted_ssr < best_cost) {
      best_cost = r.material.weighted_ssr;
      best = r.light_position;
    }
  }
  spdlog::info("lamp start from {} candidates: ({:.3f}, {:.3f}, {:.3f}) m in the {} frame",
               starts.size(), best.x(), best.y(), best.z(), ToString(options.light_frame));
  return best;
}

JointSelectionResult FitAndSelect(const ObservationSet& data, const JointFitOptions& options) {
  options.Check();
  size_t sample = 0;
  std::set<int> frames;
  for (const auto& o : data.observations) {
    sample += !o.white;
    frames.insert(o.frame);
  }
  if (sample == 0) throw InputError("no sample observations to fit");
  if (options.criterion == Criterion::kCv && frames.size() < 2) {
    throw InputError("--criterion cv: needs observations from at least 2 frames to hold out");
  }
  const Eigen::Vector3d light0 = InitialLight(data, options);
  const std::vector<std::string> names =
      options.candidates.empty() ? AutoCandidates() : options.candidates;
  const auto use = Subsample(data, options.selection_max_observations);
  JointSelectionResult out;
  out.fits.resize(names.size());
  Progress progress("joint fit candidates", names.size());
  // Candidates in parallel, each solve single-threaded.
  JointFitOptions per = options;
  per.threads = 1;
  std::mutex mutex;
  ParallelFor(names.size(), options.threads, [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      const ModelInfo& info = FindModel(names[k]);
      VisitModel(names[k], [&](auto tag) {
        using M = typename decltype(tag)::type;
        out.fits[k] = FitModel<M>(info, data, use, light0, per, true);
      });
      std::lock_guard<std::mutex> lock(mutex);
      progress.Step();
    }
  });
  progress.Done();
  for (const auto& f : out.fits) out.selection.candidates.push_back(f.material);
  ModelSelectionOptions sel;
  sel.criterion = options.criterion;
  ChooseSimplestAdequate(sel, &out.selection);
  const auto& chosen = out.fits[out.selection.selected];
  spdlog::info("selected {}; refitting on all {} observations", chosen.material.model,
               data.observations.size());
  // The final fit on (up to final_max_observations of) everything.
  const auto final_use = Subsample(data, options.final_max_observations);
  VisitModel(chosen.material.model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    out.final_fit = FitModel<M>(FindModel(chosen.material.model), data, final_use,
                                chosen.light_position, options, true);
  });
  return out;
}

}  // namespace gonio
