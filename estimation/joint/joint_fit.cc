#include "estimation/joint/joint_fit.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <set>
#include <type_traits>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"
#include "common/stats.h"
#include "estimation/joint/joint_fit_problem.h"
#include "estimation/joint/tabulated_models.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

using joint_fit_internal::BuildProblem;
using joint_fit_internal::CountResiduals;
using joint_fit_internal::Geometry;
using joint_fit_internal::HasResidual;
using joint_fit_internal::LampInBoard;
using joint_fit_internal::Predict;
using joint_fit_internal::Sigma;
using joint_fit_internal::Solve;
using joint_fit_internal::State;

}  // namespace

namespace joint_fit_internal {

std::vector<size_t> Subsample(const ObservationSet& data, size_t max_n) {
  std::vector<size_t> idx;
  const size_t n = data.observations.size();
  const size_t stride = std::max<size_t>(1, (n + max_n - 1) / std::max<size_t>(max_n, 1));
  for (size_t i = 0; i < n; i += stride) idx.push_back(i);
  return idx;
}

}  // namespace joint_fit_internal

namespace {

using joint_fit_internal::Subsample;

// Start values: the registry defaults, the given lamp, and the intensity that best scales the
// default model onto the data (weighted least squares).
template <typename M>
State InitialState(const ModelInfo& info, const ObservationSet& data,
                   const std::vector<size_t>& use, const Eigen::Vector3d& lamp_start,
                   const JointFitOptions& o) {
  State s;
  for (const auto& p : info.params) s.shared.push_back(p.default_value);
  s.chan.assign(o.per_channel ? data.channels : 1, s.shared);
  s.lamp = lamp_start;
  s.intensity = 1.0;
  s.ambient_sample.assign(data.channels, 0.0);
  s.ambient_irradiance.assign(data.channels, 0.0);
  double fy = 0, ff = 0;
  for (size_t i : use) {
    const Observation& obs = data.observations[i];
    for (int c = 0; c < data.channels; ++c) {
      const double pred = Predict<M>(obs, c, s, info, o.lamp_frame, o.white_albedo, o.patch_model);
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
  r.lamp_frame = o.lamp_frame;
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
  m.stopped_early = s.stopped_early;
  m.params = s.shared;
  for (int k = 0; k < info.num_params(); ++k) {
    if (info.params[k].per_channel) m.params[k] = s.chan[0][k];
  }
  r.lamp_position = s.lamp;
  r.intensity = s.intensity;
  r.patch_model =
      o.patch_model == PatchModel::kAverage ? PatchModel::kAverage : PatchModel::kCentre;
  r.ambient = o.ambient;
  if (o.sample_height == NuisanceTerm::kFit) r.sample_height_offset = s.height_offset;
  if (o.ambient == AmbientTerm::kFit) {
    r.ambient_sample = s.ambient_sample;
    if (o.white_albedo) r.ambient_irradiance = s.ambient_irradiance;
  }
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

}  // namespace

namespace joint_fit_internal {

// The free columns of `s`'s problem: shared, then per-channel parameters (channel c > 0 named
// "albedo[c]"), lamp x, y, z (range: its distance) and intensity. `blocks` receives the
// parameter blocks in evaluation order.
std::vector<FreeColumn> FreeColumns(const ModelInfo& info, const ceres::Problem& problem, State* s,
                                    double lamp_distance, std::vector<double*>* blocks) {
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
  blocks->push_back(s->lamp.data());
  for (int k = 0; k < 3; ++k) {
    cols.push_back({s->lamp.data(), k, lamp_distance, std::string("lamp_") + "xyz"[k]});
  }
  blocks->push_back(&s->intensity);
  cols.push_back({&s->intensity, 0, std::abs(s->intensity), "intensity"});
  if (problem.HasParameterBlock(&s->height_offset) &&
      !problem.IsParameterBlockConstant(&s->height_offset)) {
    blocks->push_back(&s->height_offset);
    cols.push_back({&s->height_offset, 0, 0.01, "sample_height"});  // range: 1 cm
  }
  // Ambient terms: ranges the lamp's irradiance at its distance (and a white Lambertian's
  // radiance under it).
  const double lamp_irradiance = std::abs(s->intensity) / (lamp_distance * lamp_distance);
  for (size_t c = 0; c < s->ambient_sample.size(); ++c) {
    if (problem.HasParameterBlock(&s->ambient_sample[c]) &&
        !problem.IsParameterBlockConstant(&s->ambient_sample[c])) {
      blocks->push_back(&s->ambient_sample[c]);
      cols.push_back({&s->ambient_sample[c], 0, lamp_irradiance * kInvPi,
                      fmt::format("ambient_sample[{}]", c)});
    }
    if (problem.HasParameterBlock(&s->ambient_irradiance[c]) &&
        !problem.IsParameterBlockConstant(&s->ambient_irradiance[c])) {
      blocks->push_back(&s->ambient_irradiance[c]);
      cols.push_back({&s->ambient_irradiance[c], 0, lamp_irradiance,
                      fmt::format("ambient_irradiance[{}]", c)});
    }
  }
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

}  // namespace joint_fit_internal

namespace {

using joint_fit_internal::FreeColumn;
using joint_fit_internal::FreeColumns;
using joint_fit_internal::FreeJacobian;

// When column c is an ambient term: its standard deviation into r's.
bool AmbientColumn(const State& s, const FreeColumn& c, std::optional<double> stddev,
                   JointFitResult* r) {
  for (size_t k = 0; k < s.ambient_sample.size(); ++k) {
    if (c.block == &s.ambient_sample[k]) {
      r->ambient_sample_stddev.resize(s.ambient_sample.size());
      r->ambient_sample_stddev[k] = stddev;
      return true;
    }
    if (c.block == &s.ambient_irradiance[k]) {
      r->ambient_irradiance_stddev.resize(s.ambient_irradiance.size());
      r->ambient_irradiance_stddev[k] = stddev;
      return true;
    }
  }
  return false;
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
  Eigen::Vector3d lamp_sd;
  bool lamp_ok = true;
  // Whether column k is the intensity or an albedo-like parameter (what a white reference fixes).
  const auto scale_column = [&](int k) {
    return k >= 0 && (cols[k].block == &s.intensity ||
                      std::any_of(s.chan.begin(), s.chan.end(),
                                  [&](const auto& ch) { return cols[k].block == ch.data(); }));
  };
  for (size_t j = 0; j < cols.size(); ++j) {
    const FreeColumn& c = cols[j];
    if (c.block == s.lamp.data()) {
      lamp_ok = lamp_ok && u.stddev[j].has_value();
      lamp_sd[c.index] = u.stddev[j].value_or(NAN);
      if (u.undetermined[j]) r->undetermined_lamp.push_back(c.name);
    } else if (c.block == &s.intensity) {
      r->intensity_stddev = u.stddev[j];
      if (u.undetermined[j]) r->undetermined_lamp.push_back("intensity");
    } else if (c.block == &s.height_offset) {
      r->sample_height_offset_stddev = u.stddev[j];
      if (u.undetermined[j]) r->undetermined_lamp.push_back("sample_height");
    } else if (AmbientColumn(s, c, u.stddev[j], r)) {
      if (u.undetermined[j]) r->undetermined_lamp.push_back(c.name);
    } else if (c.block == s.shared.data() || c.block == s.chan[0].data()) {
      m.stddev[c.index] = u.stddev[j];
      if (u.undetermined[j]) m.undetermined.push_back(c.name);
      if (c.block == s.shared.data() && scale_column(u.moves_with[j])) {
        r->moves_with_albedo.push_back(c.name);
      }
    } else if (u.undetermined[j]) {
      m.undetermined.push_back(c.name);
    }
  }
  if (lamp_ok) r->lamp_stddev = lamp_sd;
}

// The joint fit's residuals are divided by their noise model (pixel noise and the relative
// floor): the covariance is scaled by at least 1 (estimation/fit/uncertainty.h).
UncertaintyOptions JointUncertaintyOptions(const JointFitOptions& o) {
  UncertaintyOptions u = o.uncertainty;
  u.min_residual_variance = std::max(u.min_residual_variance, 1.0);
  return u;
}

// Uncertainty from the Jacobian of the plain residuals (no robust loss), free columns only
// (estimation/fit/uncertainty.h).
template <typename M>
void AnalyzeJointUncertainty(const ModelInfo& info, const ObservationSet& data,
                             const std::vector<size_t>& use, const JointFitOptions& o,
                             const State& s, JointFitResult* r) {
  State plain = s;
  ceres::Problem problem;
  BuildProblem<M>(data, use, info, o, &plain, true, &problem);
  std::vector<double*> blocks;
  const double lamp_distance = (s.lamp - data.observations[use[0]].p_in_board).norm();
  const std::vector<FreeColumn> cols = FreeColumns(info, problem, &plain, lamp_distance, &blocks);
  double cost = 0;
  const Eigen::MatrixXd J = FreeJacobian(&problem, blocks, cols, &cost);
  std::vector<double> ranges;
  for (const auto& c : cols) ranges.push_back(c.range);
  const std::vector<bool> check_fraction(cols.size(), true);
  const UncertaintyResult u =
      AnalyzeUncertainty(J, ranges, 2 * cost, check_fraction, JointUncertaintyOptions(o));
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
    LampInBoard(obs, o.lamp_frame, s.lamp.data(), lb);
    const double e = Geometry(obs, lb, ls, vs);
    e_min = std::min(e_min, e);
    e_max = std::max(e_max, e);
  }
  const double contrast = e_min > 0 ? e_max / e_min - 1.0 : 0.0;
  if (std::isfinite(e_min)) r->lamp_irradiance = s.intensity * 0.5 * (e_min + e_max);
  if (contrast >= o.min_irradiance_contrast) return;
  r->lamp_stddev.reset();
  r->undetermined_lamp.push_back("lamp_distance");
  if (!r->absolute) r->undetermined_lamp.push_back("intensity");
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
      const double res = Predict<M>(obs, c, s, info, o.lamp_frame, o.white_albedo, o.patch_model) -
                         obs.radiance[c];
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
            Predict<M>(obs, c, t, info, o.lamp_frame, o.white_albedo, o.patch_model) -
            obs.radiance[c];
        cv_sq += res * res;
        ++cv_n;
      }
    }
  }
  if (cv_n == 0) return std::nullopt;
  return std::sqrt(cv_sq / cv_n);
}

// The state a converged result of the same model stands for: its parameters (the per-channel
// ones of every channel), lamp, intensity and fitted terms (zero where `r` did not fit a term
// that `o` fits).
State StateFromResult(const ModelInfo& info, const JointFitResult& r, const ObservationSet& data,
                      const JointFitOptions& o) {
  State s;
  s.shared = r.material.params;
  s.chan.assign(o.per_channel ? data.channels : 1, s.shared);
  for (size_t c = 0; c < s.chan.size() && c < r.per_channel_params.size(); ++c) {
    size_t j = 0;
    for (int k = 0; k < info.num_params(); ++k) {
      if (info.params[k].per_channel && j < r.per_channel_params[c].size()) {
        s.chan[c][k] = r.per_channel_params[c][j++];
      }
    }
  }
  s.lamp = r.lamp_position;
  s.intensity = r.intensity;
  s.ambient_sample.assign(data.channels, 0.0);
  s.ambient_irradiance.assign(data.channels, 0.0);
  for (size_t c = 0; c < r.ambient_sample.size() && c < s.ambient_sample.size(); ++c) {
    s.ambient_sample[c] = r.ambient_sample[c];
  }
  for (size_t c = 0; c < r.ambient_irradiance.size() && c < s.ambient_irradiance.size(); ++c) {
    s.ambient_irradiance[c] = r.ambient_irradiance[c];
  }
  if (o.sample_height == NuisanceTerm::kFit) s.height_offset = r.sample_height_offset.value_or(0.0);
  return s;
}

// The bound on any parameter's shift, in its standard deviations, that evaluating the model at
// the patch centres instead of over the patches causes at state `s` (kPatchBiasMaxSd):
// sqrt(sum over residuals of ((mean - centre) / sigma)^2).
template <typename M>
double PatchBiasBound(const ModelInfo& info, const ObservationSet& data,
                      const std::vector<size_t>& use, const JointFitOptions& o, const State& s) {
  double sum = 0;
  for (size_t i : use) {
    const Observation& obs = data.observations[i];
    if (obs.white || !HasResidual(obs, o)) continue;
    for (int c = 0; c < data.channels; ++c) {
      const double centre = Predict<M>(obs, c, s, info, o.lamp_frame, o.white_albedo);
      const double mean =
          Predict<M>(obs, c, s, info, o.lamp_frame, o.white_albedo, PatchModel::kAverage);
      sum += std::pow((mean - centre) / Sigma(obs, c, o.relative_noise_floor), 2);
    }
  }
  return std::sqrt(sum);
}

// PatchModel::kAuto: solved at the patch centres; solved again over the patches, from there,
// when the centres' bias could move a parameter by more than kPatchBiasMaxSd. Returns the
// options the fit used (kCentre or kAverage), for its uncertainty and metrics.
template <typename M>
JointFitOptions SolvePatchModel(const ModelInfo& info, const ObservationSet& data,
                                const std::vector<size_t>& use, const JointFitOptions& o, State* s,
                                std::optional<double>* bound) {
  JointFitOptions used = o;
  if (o.patch_model != PatchModel::kAuto) {
    Solve<M>(data, use, info, o, s);
    return used;
  }
  used.patch_model = PatchModel::kCentre;
  Solve<M>(data, use, info, used, s);
  if (!s->usable) return used;
  *bound = PatchBiasBound<M>(info, data, use, used, *s);
  if (!(**bound > kPatchBiasMaxSd)) return used;
  used.patch_model = PatchModel::kAverage;
  State averaged = *s;
  Solve<M>(data, use, info, used, &averaged);
  spdlog::debug("{}: the patch centres' bias bounded by {:.2g} sd: fitted over the patches ({})",
                info.name, **bound, averaged.usable ? "converged" : "failed; the centres kept");
  if (!averaged.usable) {
    used.patch_model = PatchModel::kCentre;
    return used;
  }
  *s = averaged;
  return used;
}

// One model on the `use` observations from `lamp_start` (or from `warm`, a converged fit of
// the same model and options): solve, uncertainty, the lamp distance's contrast check, metrics
// and (optionally) cross-validation over frames.
template <typename M>
JointFitResult FitModel(const ModelInfo& info, const ObservationSet& data,
                        const std::vector<size_t>& use, const Eigen::Vector3d& lamp_start,
                        const JointFitOptions& options, bool cross_validate,
                        const JointFitResult* warm = nullptr) {
  using Fast = typename Tabulated<M>::type;  // estimation/joint/tabulated_models.h
  if constexpr (!std::is_same_v<Fast, M>) {
    if (options.tabulated_models) {
      return FitModel<Fast>(info, data, use, lamp_start, options, cross_validate, warm);
    }
  }
  State s = warm && warm->material.converged
                ? StateFromResult(info, *warm, data, options)
                : InitialState<M>(info, data, use, lamp_start, options);
  std::optional<double> bound;
  const JointFitOptions o = SolvePatchModel<M>(info, data, use, options, &s, &bound);
  JointFitResult r = ResultFromState(info, s, o, use.size());
  r.patch_bias_bound_sd = bound;
  r.material.n_samples = CountResiduals(data, use, o);
  if (!s.usable) return r;
  r.lamp_off_frames = data.lamp_off_frames;
  AnalyzeJointUncertainty<M>(info, data, use, o, s, &r);
  CheckIrradianceContrast(data, use, o, s, &r);
  ComputeMetrics<M>(info, data, use, o, s, &r);
  if (cross_validate) r.material.cv_rms = HeldOutFrameRms<M>(info, data, use, o, s, r.frames);
  return r;
}

}  // namespace

JointFitResult joint_fit_internal::FitCandidate(const std::string& model,
                                                const ObservationSet& data,
                                                const std::vector<size_t>& use,
                                                const Eigen::Vector3d& lamp_start,
                                                const JointFitOptions& options, bool cross_validate,
                                                const JointFitResult* warm) {
  JointFitResult r;
  VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    r = FitModel<M>(FindModel(model), data, use, lamp_start, options, cross_validate, warm);
  });
  return r;
}

bool ObservationGeometry(const Observation& o, const JointFitResult& fit, Angles<double>* angles,
                         double* irradiance_factor) {
  double lb[3], ls[3], vs[3];
  LampInBoard(o, fit.lamp_frame, fit.lamp_position.data(), lb);
  // A fitted height correction moves the sample's points along their rays, as in the fit.
  *irradiance_factor =
      Geometry(o, lb, ls, vs, o.white ? 0.0 : fit.sample_height_offset.value_or(0.0));
  if (!(ls[2] > 0)) return false;
  *angles = AnglesFromDirections(ls, vs);
  return true;
}

}  // namespace gonio
