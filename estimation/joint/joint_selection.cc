// The model search of the joint fit (docs/pipeline.md "Staged search"): candidates in stages
// of equal parameter count until one explains the data to the noise, the information-criterion
// rule, practical significance, and the final refit. One candidate's fit is FitCandidate
// (joint_fit.cc).
#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/log.h"
#include "common/parallel.h"
#include "estimation/joint/joint_fit.h"
#include "estimation/joint/joint_fit_problem.h"
#include "reflectance/registry.h"

namespace gonio {

using joint_fit_internal::CountResiduals;
using joint_fit_internal::FitCandidate;
using joint_fit_internal::Subsample;

namespace {

// The candidates in stages of equal parameter count, cheapest first (AutoCandidates and
// explicit lists alike): the staged search of docs/pipeline.md.
std::vector<std::vector<std::string>> Stages(const std::vector<std::string>& names) {
  std::map<size_t, std::vector<std::string>> by_count;
  for (const auto& n : names) by_count[FindModel(n).params.size()].push_back(n);
  std::vector<std::vector<std::string>> stages;
  for (auto& [count, group] : by_count) stages.push_back(group);
  return stages;
}

// A fit explains its data when its weighted residuals are what the noise model (pixel noise
// and the relative floor) predicts: sum z^2 / n <= 1 + 3 sqrt(2 / n), the chi-square
// distribution's mean plus three of its standard deviations.
bool ExplainsToTheNoise(const JointFitResult& f) {
  const double n = static_cast<double>(f.material.n_samples);  // the residuals the fit has
  return f.material.converged && n > 0 &&
         f.material.weighted_ssr / n <= 1.0 + 3.0 * std::sqrt(2.0 / n);
}

// The candidates of one stage, in parallel (each solve single-threaded).
std::vector<JointFitResult> FitStage(const std::vector<std::string>& names,
                                     const ObservationSet& data, const std::vector<size_t>& use,
                                     const Eigen::Vector3d& light0, const JointFitOptions& options,
                                     Progress* progress) {
  std::vector<JointFitResult> fits(names.size());
  JointFitOptions per = options;
  per.threads = 1;
  const bool cross_validate = options.criterion == Criterion::kCv;
  std::mutex mutex;
  ParallelFor(names.size(), options.threads, [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      fits[k] = FitCandidate(names[k], data, use, light0, per, cross_validate);
      std::lock_guard<std::mutex> lock(mutex);
      progress->Step();
    }
  });
  return fits;
}

// Free parameters of a candidate in the joint fit: its per-channel parameters once per channel,
// its shared ones once, the lamp position (3), the intensity (1) and the fitted ambient terms
// (two per channel at most).
size_t FreeParameters(const ModelInfo& info, int channels, const JointFitOptions& o) {
  size_t k = 4 + (o.ambient != AmbientTerm::kNone ? 2 * channels : 0) + o.fit_sample_height;
  for (const auto& p : info.params) k += (p.per_channel && o.per_channel) ? channels : 1;
  return k;
}

// Fewer residuals than a model's free parameters leave some of them anywhere: such a fit
// would report values with a meaningless (or zero) spread. Refused before any solve.
void CheckEnoughResiduals(const ObservationSet& data, const std::vector<std::string>& names,
                          const JointFitOptions& o) {
  std::vector<size_t> all(data.observations.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  const size_t n = CountResiduals(data, all, o);
  size_t fewest = SIZE_MAX;
  for (const auto& name : names) {
    fewest = std::min(fewest, FreeParameters(FindModel(name), data.channels, o));
  }
  if (n <= fewest) {
    throw InputError(fmt::format(
        "{} observation(s) give {} residual(s): too few to determine the {} free parameters "
        "of the simplest candidate (material, lamp position and intensity); extract more "
        "pixels or frames",
        data.observations.size(), n, fewest));
  }
}

// The largest relative difference between two fits' predicted radiance over the sample
// observations `use`: how far apart the two models are where the data were taken.
double MaxRelativeDifference(const JointFitResult& a, const JointFitResult& b,
                             const ObservationSet& data, const std::vector<size_t>& use) {
  double worst = 0;
  for (size_t i : use) {
    const Observation& o = data.observations[i];
    if (o.white) continue;
    Angles<double> ga, gb;
    double ea = 0, eb = 0;
    if (!ObservationGeometry(o, a, &ga, &ea) || !ObservationGeometry(o, b, &gb, &eb)) continue;
    const double la = a.material.Predict({ga.theta_i, ga.theta_r, ga.phi, 0, 1}) * a.intensity * ea;
    const double lb = b.material.Predict({gb.theta_i, gb.theta_r, gb.phi, 0, 1}) * b.intensity * eb;
    const double scale = std::max({std::abs(la), std::abs(lb), 1e-300});
    if (std::isfinite(la) && std::isfinite(lb)) worst = std::max(worst, std::abs(la - lb) / scale);
  }
  return worst;
}

// Practical significance: a richer model chosen by the criterion wins only if its prediction
// differs from the best simpler model's somewhere in the observed domain by more than the
// relative noise floor (the calibration uncertainty the fit assumes); otherwise the simpler
// model is chosen and the reason says so.
void ApplyPracticalSignificance(const ObservationSet& data, const std::vector<size_t>& use,
                                const JointFitOptions& o, JointSelectionResult* out) {
  const int chosen = out->selection.selected;
  const auto& rich = out->fits[chosen];
  int simpler = -1;
  for (int k = 0; k < static_cast<int>(out->fits.size()); ++k) {
    const auto& c = out->fits[k].material;
    if (!c.converged || c.n_params >= rich.material.n_params) continue;
    if (simpler < 0 || out->selection.CriterionValue(c) <
                           out->selection.CriterionValue(out->fits[simpler].material)) {
      simpler = k;
    }
  }
  if (simpler < 0) return;
  const double diff = MaxRelativeDifference(rich, out->fits[simpler], data, use);
  if (diff > o.relative_noise_floor) return;
  out->selection.selected = simpler;
  out->selection.reason = fmt::format(
      "{} is chosen: {} (preferred by {}) differs from it by at most {:.2f}% over the observed "
      "geometry, below the {:.1f}% calibration floor (practical significance)",
      out->fits[simpler].material.model, rich.material.model, ToString(o.criterion), 100 * diff,
      100 * o.relative_noise_floor);
}

}  // namespace

// --ambient auto: the final model refitted with the ambient terms, kept when the criterion
// (BIC, or AIC) drops by more than 2 (the same margin as the model choice).
void ChooseAmbient(const ObservationSet& data, const std::vector<size_t>& use,
                   const JointFitOptions& options, JointSelectionResult* out) {
  if (data.lamp_off_frames > 0) {
    out->final_fit.ambient_reason = "--ambient auto: lamp-off frames subtracted; no ambient term";
    return;
  }
  JointFitOptions with = options;
  with.ambient = AmbientTerm::kFit;
  const JointFitResult& none = out->final_fit;
  JointFitResult fit =
      FitCandidate(none.material.model, data, use, none.light_position, with, false);
  const bool aic = options.criterion == Criterion::kAic;
  const double c_none = aic ? none.material.aic : none.material.bic;
  const double c_fit = aic ? fit.material.aic : fit.material.bic;
  const bool keep = fit.material.converged && c_fit < c_none - 2.0;
  const std::string reason =
      fmt::format("--ambient auto: {} {:.2f} without the ambient terms, {:.2f} with them: {}",
                  aic ? "AIC" : "BIC", c_none, c_fit, keep ? "kept" : "left out");
  spdlog::info("{}", reason);
  if (keep) out->final_fit = std::move(fit);
  out->final_fit.ambient_reason = reason;
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
  const std::vector<std::string> names =
      options.candidates.empty() ? AutoCandidates() : options.candidates;
  CheckEnoughResiduals(data, names, options);
  // --ambient auto searches without the ambient terms; ChooseAmbient decides at the end.
  JointFitOptions search = options;
  if (search.ambient == AmbientTerm::kAuto) search.ambient = AmbientTerm::kNone;
  const Eigen::Vector3d light0 = InitialLight(data, search);
  const auto use = Subsample(data, options.selection_max_observations);
  JointSelectionResult out;
  Progress progress("joint fit candidates", names.size());
  std::string stopped;
  for (const auto& stage : Stages(names)) {
    const auto fits = FitStage(stage, data, use, light0, search, &progress);
    bool explained = false;
    for (const auto& f : fits) {
      explained = explained || ExplainsToTheNoise(f);
      spdlog::info("{}: weighted residual {:.3g} per residual{}", f.material.model,
                   f.material.weighted_ssr / std::max<double>(f.material.n_samples, 1),
                   ExplainsToTheNoise(f) ? " (explains the data to the noise)" : "");
      out.fits.push_back(f);
    }
    if (explained && !options.exhaustive) {
      if (out.fits.size() < names.size()) {
        stopped = fmt::format(
            "; the search stopped after {} of {} candidates: a model with {} material parameters "
            "explains the "
            "data to the noise, so richer ones were not tried",
            out.fits.size(), names.size(), FindModel(stage[0]).params.size());
      }
      break;
    }
  }
  progress.Done();
  for (const auto& f : out.fits) out.selection.candidates.push_back(f.material);
  ModelSelectionOptions sel;
  sel.criterion = options.criterion;
  ChooseSimplestAdequate(sel, &out.selection);
  ApplyPracticalSignificance(data, use, search, &out);
  out.selection.reason += stopped;
  const auto& chosen = out.fits[out.selection.selected];
  spdlog::info("selected {}; refitting on all {} observations", chosen.material.model,
               data.observations.size());
  // The final fit on (up to final_max_observations of) everything; no folds again.
  const auto final_use = Subsample(data, options.final_max_observations);
  out.final_fit =
      FitCandidate(chosen.material.model, data, final_use, chosen.light_position, search, false);
  if (options.ambient == AmbientTerm::kAuto) ChooseAmbient(data, final_use, options, &out);
  return out;
}

}  // namespace gonio
