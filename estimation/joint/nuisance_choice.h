// The choice of the nuisance terms after the model search (nuisance_choice.cc): internal to
// estimation/joint, called by FitAndSelect (joint_selection.cc).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "estimation/joint/joint_fit.h"

namespace gonio::joint_fit_internal {

// One combination of nuisance terms refitted by ChooseNuisances (the first: none, the fit
// the models were chosen by).
struct NuisanceTrial {
  bool ambient = false, height = false;
  double value = INFINITY;             // the criterion; INFINITY: a term within its error bar
  double z_ambient = 0, z_height = 0;  // each term's |value| / sd at the final size
  Eigen::Vector3d lamp = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> lamp_sd = std::nullopt;  // the lamp's statistical sd, terms free
  bool converged = false;
  BrdfFitResult material = {};  // the selected model's parameters and their statistical sd
};

// What ChooseNuisances decides and notes.
struct NuisanceChoice {
  JointFitOptions options;  // `search` with the chosen terms on (kFit)
  std::string reason;       // every combination's criterion ("-": a term within its error bar)
  // The terms left out that the data neither keep nor exclude beside the terms kept
  // (NoteEffectsOnTheLamp), and each term's NuisanceSensitivity.
  std::vector<UnresolvedNuisance> unresolved;
  std::vector<NuisanceSensitivity> sensitivity;
  // What stands when every kept term is dropped (UnkeptBesideNone;
  // JointSelectionResult::unresolved_if_kept_term_dropped).
  std::optional<UnresolvedNuisance> unresolved_if_kept_term_dropped;
};

// The nuisances (docs/pipeline.md "Nuisances chosen by evidence"): every combination of the
// kAuto ones refitted with the selected model `chosen` on the selection subsample `use`, from
// its lamp. As models are chosen: the best criterion (BIC, or AIC) among the fit without them
// and the combinations whose every term exceeds options.nuisance_min_z of the standard
// deviation it will have in the final fit (on final_n observations), then the combination with
// the fewest terms within options.nuisance_margin of it.
NuisanceChoice ChooseNuisances(const ObservationSet& data, const std::vector<size_t>& use,
                               size_t final_n, const JointFitResult& chosen,
                               const JointFitOptions& search, const JointFitOptions& options);

// What each term tried does to the lamp beside the terms picked (`pick`): its trial with the
// term on and the one with it off, the rest as picked (for a term not picked: the pick with it
// added). Each term's NuisanceSensitivity (the bars' difference at the final size: divided by
// `scale`), and each unresolved term: one not picked although it stood more than 2 of its
// final standard deviations out (within nuisance_min_z; or beyond it and the criterion against
// it) and moved the lamp by more than kShiftInSd of the lamp's bars (BenchEffects: room light at
// 5 % of the lamp, z 2.5, moves the lamp by 6 % of its distance; a 4 mm sample and room light at
// 2 %, the height kept: the room light at z 3.6 beside it lost by BIC and left the lamp 22 bars
// off). The data neither keep nor exclude it, and the result depends on it.
void NoteEffectsOnTheLamp(const std::vector<NuisanceTrial>& trials, const NuisanceTrial& pick,
                          double scale, std::vector<NuisanceSensitivity>* sensitivity,
                          std::vector<UnresolvedNuisance>* unresolved);

// What the result rests on if the terms kept (`pick`) are all dropped at the end: each term
// not kept (with one kept) or each of the two (with both kept) judged alone against the trial
// without terms (`trials`: ChooseNuisances'), on the lamp and on the material, against the bars
// at the final size (the subsample's over `scale`): the worst that stood more than 2 of its
// final standard deviations out and moved either beyond kShiftInSd. None with no term kept.
std::optional<UnresolvedNuisance> UnkeptBesideNone(const std::vector<NuisanceTrial>& trials,
                                                   const NuisanceTrial& pick, double scale);

}  // namespace gonio::joint_fit_internal
