// The calibration error's sources drawn one at a time (error_budget.h).
#include "estimation/joint/error_budget.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/option_words.h"

namespace gonio {

namespace {

constexpr OptionWord<CalibrationErrorSource> kSourceWords[] = {
    {CalibrationErrorSource::kResponse, "response"},
    {CalibrationErrorSource::kVignetting, "vignetting"},
    {CalibrationErrorSource::kPoses, "poses"}};

// What narrows each part (none: the statistical one), as docs/capture-guide.md and
// docs/photometric.md say; the response's by its sweep (SweepRemedy, calib/photometry/response.h).
std::string NarrowedBy(const std::optional<CalibrationErrorSource>& part, double period_octaves) {
  if (!part) return "more frames, or frames from more directions";
  switch (*part) {
    case CalibrationErrorSource::kResponse:
      return SweepRemedy(period_octaves);
    case CalibrationErrorSource::kVignetting:
      return "the board shown closer so its paper reaches the image corners, or a flat field";
    case CalibrationErrorSource::kPoses:
      return "more tags in view and sharper frames";
  }
  return "";
}

// The quantities of `fit` with their reported and propagated standard deviations, in the
// order of CalibrationPropagation (parameters, lamp x, y, z, intensity); undetermined ones
// carry no total.
struct Quantity {
  std::string name;
  std::optional<double> total;
};

std::vector<Quantity> QuantitiesOf(const JointFitResult& fit) {
  std::vector<Quantity> q;
  for (size_t i = 0; i < fit.material.params.size(); ++i) {
    q.push_back({fit.material.param_names[i], fit.material.stddev[i]});
  }
  for (int k = 0; k < 3; ++k) {
    q.push_back({std::string("lamp_") + "xyz"[k],
                 fit.lamp_stddev ? std::optional<double>((*fit.lamp_stddev)[k]) : std::nullopt});
  }
  q.push_back({"intensity", fit.intensity_stddev});
  return q;
}

std::vector<double> PartsOf(const CalibrationPropagation& p) {
  std::vector<double> v = p.param_stddev;
  for (int k = 0; k < 3; ++k) v.push_back(p.lamp_stddev[k]);
  v.push_back(p.intensity_stddev);
  return v;
}

}  // namespace

std::string ToString(CalibrationErrorSource source) { return OptionWordOf(kSourceWords, source); }

bool HasSource(const CalibrationErrorModel& e, CalibrationErrorSource source) {
  switch (source) {
    case CalibrationErrorSource::kResponse:
      return e.response_ratio_error > 0 || e.response_wiggle > 0 ||
             !e.response_prior_bands.empty() || !e.response_replicates.empty() ||
             std::any_of(e.response_ends.begin(), e.response_ends.end(),
                         [](const ResponseEnd& end) { return end.error > 0; });
    case CalibrationErrorSource::kVignetting:
      return e.vignette_rms > 0 ||
             std::any_of(e.vignette_kernel.truncation.begin(), e.vignette_kernel.truncation.end(),
                         [](double t) { return t != 0; });
    case CalibrationErrorSource::kPoses:
      return !e.poses.empty();
  }
  return false;
}

CalibrationErrorModel OnlySource(const CalibrationErrorModel& e, CalibrationErrorSource source) {
  CalibrationErrorModel only = e;
  if (source != CalibrationErrorSource::kResponse) {
    only.response_ratio_error = 0;
    only.response_ends.clear();
    only.response_wiggle = 0;
    only.response_prior_bands.clear();
    only.response_replicates.clear();
  }
  if (source != CalibrationErrorSource::kVignetting) {
    // V's share of the response's error stays: it is the response's (calibration_error.h).
    only.vignette_rms = 0;
    only.vignette_kernel.truncation = {};
  }
  if (source != CalibrationErrorSource::kPoses) only.poses = PoseErrorModel();
  return only;
}

std::string PartName(const std::optional<CalibrationErrorSource>& source) {
  return source ? ToString(*source) : "statistical";
}

std::optional<CalibrationErrorSource> ErrorBudgetRow::Largest(
    const std::vector<CalibrationErrorSource>& sources) const {
  std::optional<CalibrationErrorSource> largest;
  double size = statistical;
  for (size_t s = 0; s < sources.size() && s < by_source.size(); ++s) {
    if (by_source[s] && *by_source[s] > size) size = *by_source[s], largest = sources[s];
  }
  return largest;
}

CalibrationErrorBudget BudgetCalibrationError(const ObservationSet& data, const JointFitResult& fit,
                                              const JointFitOptions& fit_options,
                                              const CalibrationErrorModel& error,
                                              const CalibrationPropagation& joint,
                                              const CalibrationPropagationOptions& options) {
  CalibrationErrorBudget b;
  b.response_period_octaves = error.response_prior_period_octaves;
  std::vector<std::optional<std::vector<double>>> parts;
  for (auto s : {CalibrationErrorSource::kResponse, CalibrationErrorSource::kVignetting,
                 CalibrationErrorSource::kPoses}) {
    if (!HasSource(error, s)) continue;
    b.sources.push_back(s);
    spdlog::info("error budget: the {} error alone ({} refits)", ToString(s), options.draws);
    try {
      parts.push_back(PartsOf(
          PropagateCalibrationError(data, fit, fit_options, OnlySource(error, s), options)));
    } catch (const NumericalError& e) {
      parts.push_back(std::nullopt);
      b.notes.push_back(fmt::format("{}: {}", ToString(s), e.what()));
    }
  }
  const std::vector<double> joint_parts = PartsOf(joint);
  const std::vector<Quantity> quantities = QuantitiesOf(fit);
  for (size_t q = 0; q < quantities.size() && q < joint_parts.size(); ++q) {
    if (!quantities[q].total) continue;
    ErrorBudgetRow row;
    row.quantity = quantities[q].name;
    row.total = *quantities[q].total;
    row.statistical =
        std::sqrt(std::max(0.0, row.total * row.total - joint_parts[q] * joint_parts[q]));
    for (const auto& p : parts) {
      row.by_source.push_back(p && q < p->size() ? std::optional<double>((*p)[q]) : std::nullopt);
    }
    b.rows.push_back(std::move(row));
  }
  return b;
}

std::string CalibrationErrorBudget::Report() const {
  std::string s =
      "error budget (1 sigma; each source refitted alone, so the parts add in quadrature to the "
      "total within the refits' own spread):\n";
  s += fmt::format("  {:<12} {:>10} {:>11}", "", "total", "statistical");
  for (auto src : sources) s += fmt::format(" {:>11}", ToString(src));
  s += "\n";
  // Each part that is the largest somewhere, with the quantities it leads.
  std::vector<std::pair<std::optional<CalibrationErrorSource>, std::string>> largest;
  for (const auto& row : rows) {
    s += fmt::format("  {:<12} {:>10.3g} {:>11.3g}", row.quantity, row.total, row.statistical);
    for (const auto& v : row.by_source) s += v ? fmt::format(" {:>11.3g}", *v) : "           -";
    s += "\n";
    const std::optional<CalibrationErrorSource> part = row.Largest(sources);
    auto it = std::find_if(largest.begin(), largest.end(),
                           [&](const auto& l) { return l.first == part; });
    if (it == largest.end()) {
      largest.push_back({part, row.quantity});
    } else {
      it->second += ", " + row.quantity;
    }
  }
  for (const auto& [part, quantities] : largest) {
    s += fmt::format("  the {} part is the largest of {}: narrowed by {}\n", PartName(part),
                     quantities, NarrowedBy(part, response_period_octaves));
  }
  for (const auto& n : notes) s += "  not measured: " + n + "\n";
  return s;
}

nlohmann::json CalibrationErrorBudget::ToJson() const {
  nlohmann::json names = nlohmann::json::array(), table = nlohmann::json::object();
  for (auto src : sources) names.push_back(ToString(src));
  for (const auto& row : rows) {
    nlohmann::json by = nlohmann::json::object();
    for (size_t s = 0; s < sources.size() && s < row.by_source.size(); ++s) {
      by[ToString(sources[s])] = row.by_source[s] ? nlohmann::json(*row.by_source[s]) : nullptr;
    }
    table[row.quantity] = {{"total", row.total},
                           {"statistical", row.statistical},
                           {"sources", by},
                           {"largest", PartName(row.Largest(sources))}};
  }
  return {{"sources", names}, {"stddev", table}, {"notes", notes}};
}

}  // namespace gonio
