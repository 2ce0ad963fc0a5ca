// The model search of the joint fit (docs/pipeline.md "Staged search"): candidates in stages
// of equal parameter count until one explains the data to the noise, the information-criterion
// rule, practical significance, and the final refit. One candidate's fit is FitCandidate
// (joint_fit.cc); the nuisance terms are chosen after the search (nuisance_choice.cc).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/log.h"
#include "common/parallel.h"
#include "common/stopwatch.h"
#include "estimation/joint/joint_fit.h"
#include "estimation/joint/joint_fit_problem.h"
#include "estimation/joint/nuisance_choice.h"
#include "reflectance/registry.h"

namespace gonio {

using joint_fit_internal::ChooseNuisances;
using joint_fit_internal::CountResiduals;
using joint_fit_internal::FitCandidate;
using joint_fit_internal::NuisanceChoice;
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

// The stage (material parameter count) of the model `r`'s search selected: how far a search
// with nuisance terms must go at least (JointFitOptions::search_through_params).
size_t SelectedStage(const JointSelectionResult& r) {
  return FindModel(r.fits[r.selection.selected].material.model).params.size();
}

// A fit explains its data when its weighted residuals are what the noise model (pixel noise
// and the relative floor) predicts: sum z^2 / n <= 1 + 3 sqrt(2 / n), the chi-square
// distribution's mean plus three of its standard deviations.
bool ExplainsToTheNoise(const JointFitResult& f) {
  const double n = static_cast<double>(f.material.n_samples);  // the residuals the fit has
  return f.material.converged && n > 0 &&
         f.material.weighted_ssr / n <= 1.0 + 3.0 * std::sqrt(2.0 / n);
}

// The candidates of one stage, in parallel (each solve single-threaded). Each thread takes the
// next unfitted candidate, the costliest first (ModelInfo::cost_rank): contiguous chunks left one
// thread with the table-built and quadrature models while the other idled (a stage lasts as
// long as its slowest thread).
std::vector<JointFitResult> FitStage(const std::vector<std::string>& names,
                                     const ObservationSet& data, const std::vector<size_t>& use,
                                     const Eigen::Vector3d& light0, const JointFitOptions& options,
                                     Progress* progress) {
  std::vector<JointFitResult> fits(names.size());
  JointFitOptions per = options;
  per.threads = 1;
  const bool cross_validate = options.criterion == Criterion::kCv;
  std::vector<size_t> order(names.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return FindModel(names[a]).cost_rank > FindModel(names[b]).cost_rank;
  });
  std::atomic<size_t> next{0};
  std::mutex mutex;
  const size_t workers = std::min<size_t>(ResolveThreads(options.threads), names.size());
  ParallelFor(workers, static_cast<int>(workers), [&](size_t, size_t) {
    for (size_t i = next++; i < order.size(); i = next++) {
      const size_t k = order[i];
      const auto start = std::chrono::steady_clock::now();
      fits[k] = FitCandidate(names[k], data, use, light0, per, cross_validate);
      fits[k].fit_s = SecondsSince(start);
      std::lock_guard<std::mutex> lock(mutex);
      progress->Step();
    }
  });
  return fits;
}

// The search's fits are compared by a criterion (BIC or AIC) within a margin (the rule's and the
// nuisances', 2 by default) and by the explains-to-the-noise test; they need the criterion only
// to a small fraction of that margin, not to the 1e-10 of the cost the reported fit is solved to.
// A step that lowers the cost by a fraction t moves the criterion by about n t (n residuals: BIC
// = n log(ssr / n) + k log n), so the search's solves stop once a step is worth less than a
// hundredth of the margin, t = margin / (100 n). Their tails went on to 1e-10 for changes of the
// criterion below 0.1 (pitted-exact on a tson sample from iteration 38 to 64, li-torrance from
// 39 to the limit of 100). That holds where the robust cost is the sum of squares, near the
// noise: on the bench's samples the candidates within 10 of the best moved by at most 0.005.
// Fits far from the data (criterion thousands above the best), whose Huber cost is no longer
// the squares, stop elsewhere in their flat valleys (up to 190 of 15000 apart): the rule never
// compares them, but `--models all` is a comparison table, so it keeps the full tolerance. The
// selected model's final fit, which gives the reported values, starts from the search's
// solution and is solved to options.function_tolerance.
JointFitOptions WithSearchTolerance(const JointFitOptions& options, size_t residuals) {
  JointFitOptions o = options;
  if (options.exhaustive) return o;
  const double margin = std::min(ModelSelectionOptions{}.ic_margin, options.nuisance_margin);
  // At most 1e-3, and never tighter than the options' own (std::clamp needs lo <= hi, which a
  // function_tolerance above 1e-3 would break).
  o.function_tolerance =
      std::max(options.function_tolerance,
               std::min(margin / (100.0 * std::max<size_t>(residuals, 1)), 1e-3));
  return o;
}

// Free parameters of a candidate in the joint fit: its per-channel parameters once per channel,
// its shared ones once, the lamp position (3), the intensity (1) and the fitted ambient terms
// (two per channel at most).
size_t FreeParameters(const ModelInfo& info, int channels, const JointFitOptions& o) {
  size_t k = 4 + (o.ambient != AmbientTerm::kNone ? 2 * channels : 0) +
             (o.sample_height != NuisanceTerm::kNone);
  for (const auto& p : info.params) k += (p.per_channel && o.per_channel) ? channels : 1;
  return k;
}

// The weighted sum of squares a candidate of `stage` must get below to be selected over the
// earlier stages' `fits` (joint_fit_problem.h SearchStop): the lowest of theirs, raised by the
// most a lower numerical rank could gain it in the criterion (all its free parameters' penalty,
// exp(k max(2, log n) / n)). Infinite, so that no solve stops, for `--models all` (a comparison
// table) and cross-validation (held-out error, not the sum of squares, decides).
double SsrToBeat(const std::vector<JointFitResult>& fits, const std::vector<std::string>& stage,
                 int channels, const JointFitOptions& o) {
  if (o.exhaustive || o.criterion == Criterion::kCv) return INFINITY;
  double best = INFINITY, n = 0;
  for (const auto& f : fits) {
    if (!f.material.converged || !(f.material.weighted_ssr > 0)) continue;
    best = std::min(best, f.material.weighted_ssr);
    n = static_cast<double>(f.material.n_samples);
  }
  if (!std::isfinite(best) || !(n > 1)) return INFINITY;
  size_t k = 0;
  for (const auto& name : stage) k = std::max(k, FreeParameters(FindModel(name), channels, o));
  return best * std::exp(static_cast<double>(k) * std::max(2.0, std::log(n)) / n);
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

namespace {

// The staged search into out->fits and out->selection: stages of equal parameter count until
// one explains the data to the noise (all of them with options.exhaustive), the rule, and
// practical significance.
void SearchModels(const ObservationSet& data, const std::vector<std::string>& names,
                  const std::vector<size_t>& use, const Eigen::Vector3d& light0,
                  const JointFitOptions& search, JointSelectionResult* out) {
  out->fits.clear();
  out->selection = {};
  Progress progress("joint fit candidates", names.size());
  std::string stopped;
  for (const auto& stage : Stages(names)) {
    JointFitOptions stage_options = search;
    stage_options.search_weighted_ssr_to_beat = SsrToBeat(out->fits, stage, data.channels, search);
    const auto fits = FitStage(stage, data, use, light0, stage_options, &progress);
    bool explained = false;
    for (const auto& f : fits) {
      explained = explained || ExplainsToTheNoise(f);
      spdlog::info("{}: weighted residual {:.3g} per residual{} ({:.2f} s)", f.material.model,
                   f.material.weighted_ssr / std::max<double>(f.material.n_samples, 1),
                   ExplainsToTheNoise(f) ? " (explains the data to the noise)" : "", f.fit_s);
      out->fits.push_back(f);
    }
    if (explained && !search.exhaustive &&
        FindModel(stage[0]).params.size() >= search.search_through_params) {
      if (out->fits.size() < names.size()) {
        stopped = fmt::format(
            "; the search stopped after {} of {} candidates: a model with {} material parameters "
            "explains the "
            "data to the noise, so richer ones were not tried",
            out->fits.size(), names.size(), FindModel(stage[0]).params.size());
      }
      break;
    }
  }
  progress.Done();
  for (const auto& f : out->fits) out->selection.candidates.push_back(f.material);
  ModelSelectionOptions sel;
  sel.criterion = search.criterion;
  ChooseSimplestAdequate(sel, &out->selection);
  ApplyPracticalSignificance(data, use, search, out);
  out->selection.reason += stopped;
}

// The search without nuisances (`without`) restored, its selected model refitted on
// `final_use` from its own solution; `search`: the options without the kAuto terms.
JointSelectionResult RestoreWithoutNuisances(const ObservationSet& data,
                                             const std::vector<size_t>& final_use,
                                             const JointFitOptions& search,
                                             const JointSelectionResult& without) {
  JointSelectionResult out = without;
  const JointFitResult& chosen = out.fits[out.selection.selected];
  out.final_fit = FitCandidate(chosen.material.model, data, final_use, chosen.lamp_position, search,
                               false, &chosen);
  return out;
}

// After a drop that left `f` without any nuisance term: a term the selection judged alone
// against none (JointSelectionResult::unresolved_if_kept_term_dropped: the one the dropped term
// beat by the criterion, or either of two kept and dropped), judged again against `f`'s bars;
// none while `f` keeps a term or when its shift is within them.
std::optional<UnresolvedNuisance> JudgedAloneWhenNoTermIsLeft(
    const std::optional<UnresolvedNuisance>& candidate, const JointFitResult& f) {
  if (!candidate || !f.ambient_sample.empty() || f.sample_height_offset) return std::nullopt;
  UnresolvedNuisance u = *candidate;
  if (!u.JudgeAgainst(f)) return std::nullopt;
  return u;
}

// A nuisance kept on the selection subsample must stand out of its error bar in the final fit
// too: ChooseNuisances predicts the final bar from the subsample's (1 / sqrt(n)), and a
// calibration error's smooth bend, which does not average out, can pass that test and then sit
// within its bar on all observations (an 8-bit sRGB camera's ambient radiance: z 1.5 at the end
// after a predicted 3+; the constant traded against the lamp, albedo -1.2 %, lamp 1.1 %). Such a
// term is dropped: the selection without the kept terms, and its final fit, are restored (one
// term of two: the other stays, refitted), and when the kept term had moved the lamp beyond
// kShiftInSd of its bars, the term is noted as unresolved (UnresolvedAfterDrop).
void DropUnsupportedNuisances(const ObservationSet& data, const std::vector<size_t>& final_use,
                              const JointFitOptions& search, const JointFitOptions& options,
                              const JointSelectionResult& without, std::string* reason,
                              JointSelectionResult* out,
                              std::vector<UnresolvedNuisance>* unresolved) {
  const NuisanceDrop drop = NuisancesWithinTheirBars(options, out->final_fit);
  if (!drop.Any()) return;
  const auto if_kept_dropped = out->unresolved_if_kept_term_dropped;
  const JointFitResult kept = out->final_fit;
  *reason += fmt::format("; on all {} observations {} within {:g} standard deviations: dropped",
                         final_use.size(), drop.Named(), options.nuisance_min_z);
  spdlog::info("nuisances: {}", *reason);
  JointFitOptions o = search;
  if (drop.ambient_kept && !drop.ambient) o.ambient = AmbientTerm::kFit;
  if (drop.height_kept && !drop.height) o.sample_height = NuisanceTerm::kFit;
  if (o.ambient != AmbientTerm::kFit && o.sample_height != NuisanceTerm::kFit) {
    *out = RestoreWithoutNuisances(data, final_use, search, without);
  } else {
    // One term of two stays: the selected model refitted with it (a fit with another term set
    // does not start from the selection's solution: FitCandidate's warm start).
    const JointFitResult& chosen = out->fits[out->selection.selected];
    out->final_fit =
        FitCandidate(chosen.material.model, data, final_use, chosen.lamp_position, o, false);
  }
  // This beside a term ChooseNuisances left unresolved beside the dropped one (the worse when
  // both are the same term); a term judged alone against none only when neither is: the terms
  // the selection kept had the stronger evidence (on the glossy kind 4 mm up the dropped height
  // moved sigma 25 bars, the room light judged alone the albedo 36, and the height is what was
  // there).
  KeepTheWorseOfItsTerm(UnresolvedAfterDrop(drop, kept, out->final_fit), unresolved);
  if (unresolved->empty()) {
    KeepTheWorseOfItsTerm(JudgedAloneWhenNoTermIsLeft(if_kept_dropped, out->final_fit), unresolved);
  }
}

// `options` with its kAuto nuisance terms off: what the model search fits.
JointFitOptions WithoutAutoNuisances(JointFitOptions options) {
  if (options.ambient == AmbientTerm::kAuto) options.ambient = AmbientTerm::kNone;
  if (options.sample_height == NuisanceTerm::kAuto) options.sample_height = NuisanceTerm::kNone;
  return options;
}

// How far a search with terms forced on (--ambient fit, --sample-height fit) must go at least:
// its stopping rule would end at the first stage the data are explained in with the terms'
// help, and a term can mimic part of a material's shape (JointFitOptions::search_through_params;
// with the height forced, Lambert explained a dark Oren-Nayar sample 4 mm up to its 2.4 % floor
// with the sample 35 mm up and the albedo on its bound). The search without the terms says.
// `search`'s own value when nothing is forced, one candidate is listed, every candidate is
// fitted anyway or the caller set it.
size_t StageOfTheSearchWithoutForcedTerms(const ObservationSet& data,
                                          const std::vector<std::string>& names,
                                          const std::vector<size_t>& use,
                                          const Eigen::Vector3d& light0,
                                          const JointFitOptions& search) {
  const bool forced =
      search.ambient == AmbientTerm::kFit || search.sample_height == NuisanceTerm::kFit;
  if (!forced || names.size() < 2 || search.exhaustive || search.search_through_params > 0) {
    return search.search_through_params;
  }
  spdlog::info(
      "searching the models without the forced nuisance terms first: the search with "
      "them goes at least as far");
  JointFitOptions bare = search;
  bare.ambient = AmbientTerm::kNone;
  bare.sample_height = NuisanceTerm::kNone;
  JointSelectionResult without;
  SearchModels(data, names, use, light0, bare, &without);
  return SelectedStage(without);
}

}  // namespace

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
  // kAuto nuisances: the search without them; ChooseNuisances decides after it.
  JointFitOptions search = WithoutAutoNuisances(options);
  const Eigen::Vector3d light0 = InitialLamp(data, search);
  const auto use = Subsample(data, options.selection_max_observations);
  // The reported fits (the final one, a restored selection's) are solved to the options'
  // tolerance; the search's to the criterion's (WithSearchTolerance).
  const JointFitOptions refit = search;
  search = WithSearchTolerance(search, CountResiduals(data, use, search));
  // The candidates are compared at their patches' centres (a bias common to them all); the
  // reported fits model the patch as `options` says (PatchModel).
  search.patch_model = PatchModel::kCentre;
  search.search_through_params =
      StageOfTheSearchWithoutForcedTerms(data, names, use, light0, search);
  JointSelectionResult out;
  SearchModels(data, names, use, light0, search, &out);
  const auto final_use = Subsample(data, options.final_max_observations);
  NuisanceChoice choice = ChooseNuisances(data, use, final_use.size(),
                                          out.fits[out.selection.selected], search, options);
  const JointFitOptions& chosen_options = choice.options;
  std::string& nuisance_reason = choice.reason;
  std::vector<UnresolvedNuisance>& unresolved = choice.unresolved;
  auto without_nuisances = std::make_shared<const JointSelectionResult>(out);
  if (chosen_options.ambient != search.ambient ||
      chosen_options.sample_height != search.sample_height) {
    // A kept nuisance can change which model explains the data: search again with it, at
    // least up to the stage of the model selected without it (a nuisance term can mimic some
    // of a material's shape; the criterion, not the stopping rule, must decide that).
    spdlog::info("searching the models again with the kept nuisance terms");
    const Eigen::Vector3d lamp = out.fits[out.selection.selected].lamp_position;
    JointFitOptions with_terms = chosen_options;
    with_terms.search_through_params = std::max(search.search_through_params, SelectedStage(out));
    SearchModels(data, names, use, lamp, with_terms, &out);
  }
  const auto& chosen = out.fits[out.selection.selected];
  spdlog::info("selected {}; refitting on all {} observations", chosen.material.model,
               data.observations.size());
  // The final fit on (up to final_max_observations of) everything; no folds again. It starts
  // from the chosen candidate's solution on the subsample, which is within its noise of the
  // final one, instead of descending again from the registry defaults (the search's largest
  // single cost for the expensive models: 10x the subsample, docs/bench.md).
  JointFitOptions final_options = chosen_options;
  final_options.function_tolerance = refit.function_tolerance;
  final_options.patch_model = refit.patch_model;
  out.final_fit = FitCandidate(chosen.material.model, data, final_use, chosen.lamp_position,
                               final_options, false, &chosen);
  out.unresolved_if_kept_term_dropped = choice.unresolved_if_kept_term_dropped;
  DropUnsupportedNuisances(data, final_use, refit, options, *without_nuisances, &nuisance_reason,
                           &out, &unresolved);
  out.final_fit.unresolved_nuisances = unresolved;
  out.final_fit.nuisance_sensitivity = choice.sensitivity;
  if (options.ambient == AmbientTerm::kAuto) out.final_fit.ambient_reason = nuisance_reason;
  if (options.sample_height == NuisanceTerm::kAuto) {
    out.final_fit.sample_height_reason = nuisance_reason;
  }
  const NuisanceDrop kept = NuisancesWithinTheirBars(options, out.final_fit);
  if (kept.ambient_kept || kept.height_kept) {
    out.without_nuisances = std::move(without_nuisances);
  }
  return out;
}

JointSelectionResult DropNuisances(const ObservationSet& data, const JointFitOptions& options,
                                   const NuisanceDrop& drop,
                                   const JointSelectionResult& selection) {
  options.Check();
  if (!drop.Any()) return selection;
  JointSelectionResult out;
  if ((drop.ambient_kept && !drop.ambient) || (drop.height_kept && !drop.height)) {
    // One of two kept terms stays: the models are searched again with it on (kFit), as the
    // selection with both may not be the one with either alone. The search goes at least as
    // far as the one without nuisances: a height correction alone
    // let a Lambertian fit explain an Oren-Nayar sample to the noise floor with the sample
    // 34 mm up (4 mm true), where the search with both terms had kept Oren-Nayar. It starts
    // from the lamp the fit with both found: from the multi-start's, the glossy sample's tson
    // (its truth) stopped at 300 per residual, and a Li-Torrance with the sample 36 mm up won.
    JointFitOptions o = WithChosenNuisances(options, selection.final_fit);
    if (drop.ambient) o.ambient = AmbientTerm::kNone;
    if (drop.height) o.sample_height = NuisanceTerm::kNone;
    const Eigen::Vector3d& lamp = selection.final_fit.lamp_position;
    if (!o.lamp_init && lamp.allFinite() && lamp.norm() <= kMaxLampDistance) o.lamp_init = lamp;
    if (selection.without_nuisances) {
      o.search_through_params =
          std::max(o.search_through_params, SelectedStage(*selection.without_nuisances));
    }
    out = FitAndSelect(data, o);
  } else if (!selection.without_nuisances) {
    throw std::logic_error("DropNuisances: the selection holds no search without its nuisances");
  } else {
    out = RestoreWithoutNuisances(data, Subsample(data, options.final_max_observations),
                                  WithoutAutoNuisances(options), *selection.without_nuisances);
  }
  // The terms' trials were made by the selection; neither refit above tries the dropped term.
  out.final_fit.nuisance_sensitivity = selection.final_fit.nuisance_sensitivity;
  // gonio run notes the dropped term itself after this (pipeline/run.cc NoteDrop), in place of
  // this one: as in DropUnsupportedNuisances, the kept terms had the stronger evidence.
  out.final_fit.unresolved_nuisances.clear();
  KeepTheWorseOfItsTerm(
      JudgedAloneWhenNoTermIsLeft(selection.unresolved_if_kept_term_dropped, out.final_fit),
      &out.final_fit.unresolved_nuisances);
  return out;
}

}  // namespace gonio
