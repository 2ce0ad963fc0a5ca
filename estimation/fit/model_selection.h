// Model selection: fit every candidate, compare by AIC, BIC or K-fold cross-validation, and
// choose the simplest model the data supports ("model no more than a scene needs").
//
// Rule: find the best criterion value; among candidates within `margin` of it (AIC/BIC: an
// absolute margin, 2 by default, the usual "substantial support" threshold of Burnham and
// Anderson; CV: a relative margin on cv_rms), choose the one with the fewest parameters, and
// among those the best criterion.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "estimation/fit/brdf_fit.h"

namespace gonio {

// What candidates are compared by: AIC, BIC, or the RMS of K-fold cross-validation.
enum class Criterion { kAic, kBic, kCv };
// "aic", "bic" or "cv"; InputError naming `option_name` otherwise.
Criterion ParseCriterion(const std::string& word, const std::string& option_name);
std::string ToString(Criterion criterion);

struct ModelSelectionOptions {
  std::vector<std::string> candidates;  // empty: AutoCandidates()
  Criterion criterion = Criterion::kBic;
  double ic_margin = 2.0;
  double cv_margin = 0.02;
  int cv_folds = 5;
  int threads = 0;  // candidates are fitted in parallel; <= 0: all cores
  BrdfFitOptions fit;

  void Check() const;
};

struct ModelSelectionResult {
  std::vector<BrdfFitResult> candidates;
  int selected = -1;
  Criterion criterion = Criterion::kBic;
  std::string reason;
  std::vector<std::string> skipped;  // "model: why"
  // Converged candidates with as many parameters as the selected one and a criterion within the
  // margin of its value (indices into candidates): the data do not tell them from it, and the
  // rule, which breaks ties only by parameter count, picked the lowest value among equals.
  std::vector<int> rivals;

  const BrdfFitResult& Selected() const { return candidates.at(selected); }
  double CriterionValue(const BrdfFitResult& r) const;
  // "oren-nayar (bic +1.77)": candidate k and its criterion against the selected one's.
  std::string RivalText(int k) const;
  std::string Report() const;
};

// Every registered model marked auto_candidate (ModelInfo), cheapest first.
std::vector<std::string> AutoCandidates();

// InputError when no candidate can be fitted (e.g. fewer samples than any model's parameters).
ModelSelectionResult SelectModel(const std::vector<BrdfSample>& samples,
                                 const ModelSelectionOptions& options);

// Fills selected, criterion and reason from already fitted candidates (AIC/BIC/cv_rms set) by
// the rule above. NumericalError when no candidate converged. Shared with the joint fit.
void ChooseSimplestAdequate(const ModelSelectionOptions& options, ModelSelectionResult* result);

nlohmann::json ToJson(const BrdfFitResult& fit);
nlohmann::json ToJson(const ModelSelectionResult& selection);

}  // namespace gonio
