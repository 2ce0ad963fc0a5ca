// The choice of the nuisance terms after the model search (nuisance_choice.cc): internal to
// estimation/joint, called by FitAndSelect (joint_selection.cc).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "estimation/joint/joint_fit.h"

namespace gonio::joint_fit_internal {

// The nuisances (docs/pipeline.md "Nuisances chosen by evidence"): every combination of the
// kAuto ones refitted with the selected model `chosen` on the selection subsample `use`, from
// its lamp. As models are chosen: the best criterion (BIC, or AIC) among the fit without them
// and the combinations whose every term exceeds options.nuisance_min_z of the standard
// deviation it will have in the final fit (on final_n observations), then the combination with
// the fewest terms within options.nuisance_margin of it. Returns `search` with the chosen terms
// on (kFit); `reason` lists every criterion value ("-": a term within its error bar);
// `unresolved` and `sensitivity` receive what each term tried does to the lamp.
JointFitOptions ChooseNuisances(const ObservationSet& data, const std::vector<size_t>& use,
                                size_t final_n, const JointFitResult& chosen,
                                const JointFitOptions& search, const JointFitOptions& options,
                                std::string* reason, std::optional<UnresolvedNuisance>* unresolved,
                                std::vector<NuisanceSensitivity>* sensitivity);

}  // namespace gonio::joint_fit_internal
