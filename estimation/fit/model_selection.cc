#include "estimation/fit/model_selection.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "common/error.h"
#include "common/option_words.h"
#include "common/parallel.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

constexpr OptionWord<Criterion> kCriterionWords[] = {
    {Criterion::kAic, "aic"}, {Criterion::kBic, "bic"}, {Criterion::kCv, "cv"}};

}  // namespace

Criterion ParseCriterion(const std::string& word, const std::string& option_name) {
  return ParseOptionWord(kCriterionWords, word, option_name);
}

std::string ToString(Criterion criterion) { return OptionWordOf(kCriterionWords, criterion); }

void ModelSelectionOptions::Check() const {
  if (!(ic_margin >= 0) || !(cv_margin >= 0)) throw InputError("selection margins must be >= 0");
  if (cv_folds < 2 || cv_folds > 50) throw InputError("cv folds must be in [2, 50]");
  for (const auto& c : candidates) FindModel(c);
  fit.Check();
}

std::vector<std::string> AutoCandidates() {
  std::vector<ModelInfo> models;
  for (const auto& m : RegisteredModels()) {
    if (m.auto_candidate) models.push_back(m);
  }
  std::stable_sort(models.begin(), models.end(), [](const ModelInfo& a, const ModelInfo& b) {
    return a.cost_rank != b.cost_rank ? a.cost_rank < b.cost_rank : a.num_params() < b.num_params();
  });
  std::vector<std::string> names;
  for (const auto& m : models) names.push_back(m.name);
  return names;
}

double ModelSelectionResult::CriterionValue(const BrdfFitResult& r) const {
  switch (criterion) {
    case Criterion::kAic:
      return r.aic;
    case Criterion::kBic:
      return r.bic;
    case Criterion::kCv:
      break;
  }
  return r.cv_rms.value_or(INFINITY);
}

ModelSelectionResult SelectModel(const std::vector<BrdfSample>& samples,
                                 const ModelSelectionOptions& options) {
  options.Check();
  ModelSelectionResult out;
  out.criterion = options.criterion;
  const std::vector<std::string> names =
      options.candidates.empty() ? AutoCandidates() : options.candidates;

  std::vector<std::string> fit_names;
  // Repeated rows of one geometry say nothing more about a model's shape (brdf_fit.h).
  const size_t geometries = DistinctGeometries(samples);
  for (const auto& name : names) {
    const int free = FindModel(name).num_params() + (options.fit.relative_scale ? 1 : 0);
    if (static_cast<int>(geometries) <= free) {
      // An explicit request the data cannot support is an error; auto just skips it.
      if (!options.candidates.empty()) {
        throw InputError(
            fmt::format("{} samples at {} distinct geometries cannot determine {}'s {} free "
                        "parameters (needs at least {} geometries)",
                        samples.size(), geometries, name, free, free + 1));
      }
      out.skipped.push_back(name + ": more parameters than distinct geometries");
      continue;
    }
    fit_names.push_back(name);
  }
  if (fit_names.empty()) {
    throw InputError(
        fmt::format("{} samples at {} distinct geometries are too few for any "
                    "candidate model",
                    samples.size(), geometries));
  }

  out.candidates.resize(fit_names.size());
  ParallelFor(fit_names.size(), options.threads, [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      out.candidates[k] = FitBrdf(fit_names[k], samples, options.fit);
      if (out.candidates[k].converged) {
        out.candidates[k].cv_rms =
            CrossValidationRms(out.candidates[k], samples, options.fit, options.cv_folds);
      }
    }
  });

  ChooseSimplestAdequate(options, &out);
  return out;
}

void ChooseSimplestAdequate(const ModelSelectionOptions& options, ModelSelectionResult* result) {
  ModelSelectionResult& out = *result;
  out.criterion = options.criterion;
  int best = -1;
  for (int k = 0; k < static_cast<int>(out.candidates.size()); ++k) {
    const auto& c = out.candidates[k];
    if (!c.converged || !std::isfinite(out.CriterionValue(c))) continue;
    if (best < 0 || out.CriterionValue(c) < out.CriterionValue(out.candidates[best])) best = k;
  }
  if (best < 0) throw NumericalError("no candidate model converged on these samples");
  const double best_value = out.CriterionValue(out.candidates[best]);
  const double limit = options.criterion == Criterion::kCv ? best_value * (1.0 + options.cv_margin)
                                                           : best_value + options.ic_margin;
  int chosen = best;
  for (int k = 0; k < static_cast<int>(out.candidates.size()); ++k) {
    const auto& c = out.candidates[k];
    if (!c.converged || !(out.CriterionValue(c) <= limit)) continue;
    const auto& s = out.candidates[chosen];
    if (c.n_params < s.n_params ||
        (c.n_params == s.n_params && out.CriterionValue(c) < out.CriterionValue(s))) {
      chosen = k;
    }
  }
  out.selected = chosen;
  const auto& sel = out.candidates[chosen];
  const std::string margin_text = options.criterion == Criterion::kCv
                                      ? fmt::format("{:.0f}%", 100 * options.cv_margin)
                                      : fmt::format("{:g}", options.ic_margin);
  if (chosen == best) {
    out.reason = fmt::format(
        "{} has the best {} ({:.6g}); no model with fewer parameters comes "
        "within {} of it",
        sel.model, ToString(options.criterion), best_value, margin_text);
  } else {
    out.reason = fmt::format(
        "{} ({} parameters, {} {:.6g}) is within {} of the best, {} ({} parameters, {:.6g}), "
        "so the simpler model is chosen",
        sel.model, sel.n_params, ToString(options.criterion), out.CriterionValue(sel), margin_text,
        out.candidates[best].model, out.candidates[best].n_params, best_value);
  }
  const double rival_limit = options.criterion == Criterion::kCv
                                 ? out.CriterionValue(sel) * (1.0 + options.cv_margin)
                                 : out.CriterionValue(sel) + options.ic_margin;
  out.rivals.clear();
  for (int k = 0; k < static_cast<int>(out.candidates.size()); ++k) {
    const auto& c = out.candidates[k];
    if (k == chosen || !c.converged || c.n_params != sel.n_params) continue;
    if (out.CriterionValue(c) <= rival_limit) out.rivals.push_back(k);
  }
  std::vector<std::string> rivals;
  for (int k : out.rivals) rivals.push_back(out.RivalText(k));
  if (!rivals.empty()) {
    out.reason += fmt::format("; with as many parameters and within {} of it: {}", margin_text,
                              fmt::join(rivals, ", "));
  }
  if (!sel.undetermined.empty()) {
    std::string names_text;
    for (const auto& u : sel.undetermined) names_text += (names_text.empty() ? "" : ", ") + u;
    out.reason += "; the data cannot determine: " + names_text;
  }
}

std::string ModelSelectionResult::Report() const {
  std::ostringstream s;
  s << fmt::format("{:<28} {:>3} {:>9} {:>11} {:>11} {:>10}\n", "model", "k", "rel_rms", "aic",
                   "bic", "cv_rms");
  for (int k = 0; k < static_cast<int>(candidates.size()); ++k) {
    const auto& c = candidates[k];
    if (!c.converged) {
      s << fmt::format("{:<28} did not converge\n", c.model);
      continue;
    }
    s << fmt::format("{:<28} {:>3} {:>9.4f} {:>11.2f} {:>11.2f} {:>10}{}\n", c.model, c.n_params,
                     c.rel_rms, c.aic, c.bic,
                     c.cv_rms ? fmt::format("{:.4g}", *c.cv_rms) : std::string("-"),
                     k == selected     ? "  <- selected"
                     : c.stopped_early ? "  (stopped: cannot win)"
                                       : "");
  }
  s << "selected: " << reason << "\n";
  if (selected >= 0) s << Selected().Report() << "\n";
  return s.str();
}

namespace {
nlohmann::json OptionalNumber(const std::optional<double>& v) {
  return v && std::isfinite(*v) ? nlohmann::json(*v) : nlohmann::json(nullptr);
}
nlohmann::json FiniteOrNull(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}
}  // namespace

nlohmann::json ToJson(const BrdfFitResult& fit) {
  nlohmann::json params = nlohmann::json::object(), stddev = nlohmann::json::object();
  for (size_t k = 0; k < fit.param_names.size(); ++k) {
    params[fit.param_names[k]] = FiniteOrNull(fit.params[k]);
    stddev[fit.param_names[k]] = OptionalNumber(fit.stddev[k]);
  }
  nlohmann::json j = {{"model", fit.model},
                      {"params", params},
                      {"stddev", stddev},
                      {"undetermined", fit.undetermined},
                      {"n_params", fit.n_params},
                      {"n_effective", fit.n_effective},
                      {"rms", FiniteOrNull(fit.rms)},
                      {"rel_rms", FiniteOrNull(fit.rel_rms)},
                      {"aic", FiniteOrNull(fit.aic)},
                      {"bic", FiniteOrNull(fit.bic)},
                      {"cv_rms", OptionalNumber(fit.cv_rms)},
                      {"converged", fit.converged}};
  if (fit.stopped_early) j["stopped_early"] = true;
  if (fit.scale != 1.0 || fit.scale_stddev) {
    j["scale"] = FiniteOrNull(fit.scale);
    j["scale_stddev"] = OptionalNumber(fit.scale_stddev);
  }
  if (!fit.message.empty()) j["message"] = fit.message;
  return j;
}

std::string ModelSelectionResult::RivalText(int k) const {
  const BrdfFitResult& c = candidates.at(k);
  return fmt::format("{} ({} {:+.3g})", c.model, ToString(criterion),
                     CriterionValue(c) - CriterionValue(Selected()));
}

nlohmann::json ToJson(const ModelSelectionResult& selection) {
  nlohmann::json candidates = nlohmann::json::array();
  for (const auto& c : selection.candidates) candidates.push_back(ToJson(c));
  nlohmann::json rivals = nlohmann::json::array();
  for (int k : selection.rivals) rivals.push_back(selection.RivalText(k));
  return {{"selected", selection.selected >= 0 ? selection.Selected().model : ""},
          {"criterion", ToString(selection.criterion)},
          {"reason", selection.reason},
          {"n_samples", selection.candidates.empty() ? 0 : selection.candidates[0].n_samples},
          {"skipped", selection.skipped},
          {"rivals", rivals},
          {"candidates", candidates}};
}

}  // namespace gonio
