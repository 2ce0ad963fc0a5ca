#include "pipeline/checks.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "reflectance/registry.h"

namespace gonio {

void CheckBitDepths(int session_bit_depth, const ResponseResult& response,
                    const std::string& session_what, const std::string& photometric_what) {
  if (session_bit_depth > 0 && session_bit_depth != response.bit_depth) {
    throw InputError(fmt::format(
        "{}: calibrated for {}-bit values, but {} says the frames are {}-bit; calibrate this "
        "camera mode or correct session.json's bit_depth",
        photometric_what, response.bit_depth, session_what, session_bit_depth));
  }
}

void CheckObservationValues(const ObservationSet& data, const std::string& what) {
  // Beyond 1e150 a square (every residual, every variance sum) overflows a double: the fit
  // would report infinities, so such a value is no radiance gonio can take.
  constexpr double kLargest = 1e150;
  size_t sample = 0, negative = 0;
  for (const auto& o : data.observations) {
    for (size_t c = 0; c < o.radiance.size(); ++c) {
      const double L = o.radiance[c], var = c < o.variance.size() ? o.variance[c] : 0;
      if (!(std::abs(L) <= kLargest && var >= 0 && var <= kLargest)) {
        throw InputError(fmt::format(
            "{}: frame {} pixel ({:.1f}, {:.1f}): radiance {:g} with variance {:g} is beyond what "
            "a fit can square (|L| and variance up to {:g})",
            what, o.frame, o.px, o.py, L, var, kLargest));
      }
    }
    if (o.white) continue;
    ++sample;
    for (size_t c = 0; c < o.radiance.size(); ++c) {
      const double sigma = c < o.variance.size() ? std::sqrt(o.variance[c]) : 0;
      if (o.radiance[c] < -3 * sigma) {
        ++negative;
        break;
      }
    }
  }
  if (sample > 0 && negative > kMaxNegativeFraction * sample) {
    throw InputError(fmt::format(
        "{}: {} of {} sample observations ({:.1f}%) are more than 3 sigma below zero; radiance "
        "is never negative (a wrong black level, lamp-off frames of another exposure, or "
        "edited values?)",
        what, negative, sample, 100.0 * negative / sample));
  }
}

CheckedFit FitChecked(const ObservationSet& data, const JointFitOptions& fit_options,
                      const std::string& what, const FitChecksOptions& options) {
  options.Check();
  CheckObservationValues(data, what);
  CheckedFit r;
  r.fit = FitAndSelect(data, fit_options);
  r.checks = CheckFit(r.fit, data, fit_options, what, options);
  return r;
}

void FitChecksOptions::Check() const {
  if (!(frame_floor_multiple > 0)) throw InputError("frame_floor_multiple must be > 0");
  if (!(max_inconsistent_fraction > 0 && max_inconsistent_fraction <= 1)) {
    throw InputError("max_inconsistent_fraction must be in (0, 1]");
  }
  if (!(max_rms_sigma > 0)) throw InputError("max_rms_sigma must be > 0");
  if (!(bound_fraction >= 0 && bound_fraction < 0.5)) {
    throw InputError("bound_fraction must be in [0, 0.5)");
  }
}

namespace {

// Parameters within `fraction` of their range from a registry bound: fit bounds in *at_bound,
// edges of the model's own domain (ParamInfo::min/max_is_domain_edge) in *at_edge.
void ParametersAtBounds(const BrdfFitResult& m, double fraction, std::vector<std::string>* at_bound,
                        std::vector<std::string>* at_edge) {
  const ModelInfo& info = FindModel(m.model);
  for (size_t k = 0; k < m.params.size() && k < info.params.size(); ++k) {
    const ParamInfo& p = info.params[k];
    const double tol = fraction * (p.max - p.min);
    const bool low = m.params[k] <= p.min + tol, high = m.params[k] >= p.max - tol;
    if (!low && !high) continue;
    const bool edge = low ? p.min_is_domain_edge : p.max_is_domain_edge;
    const std::string unit = p.unit == "1" ? "" : " " + p.unit;
    (edge ? at_edge : at_bound)
        ->push_back(fmt::format("{} ({} {} {:g}{})", p.name, low ? "lower" : "upper",
                                edge ? "end of the model's domain," : "bound", low ? p.min : p.max,
                                unit));
  }
}

double RmsSigma(const JointFitResult& f) {
  double sum_sq = 0;
  size_t n = 0;
  for (const auto& fr : f.frames) {
    sum_sq += fr.rms_sigma * fr.rms_sigma * fr.n;
    n += fr.n;
  }
  return n ? std::sqrt(sum_sq / n) : 0;
}

// The selected model fitted to the frames with mean relative residual below (part 0) or above
// (part 1) `threshold`; true when both parts are explained on their own.
bool BothPartsExplained(const JointSelectionResult& fit, const ObservationSet& data,
                        const JointFitOptions& fit_options, double threshold,
                        double max_rms_sigma) {
  std::set<int> upper;
  for (const auto& fr : fit.final_fit.frames) {
    if (fr.mean_relative > threshold) upper.insert(fr.frame);
  }
  JointFitOptions o = fit_options;
  o.candidates = {fit.final_fit.material.model};
  o.light_init = std::nullopt;
  for (int part = 0; part < 2; ++part) {
    ObservationSet subset = data;
    subset.observations.clear();
    for (const auto& obs : data.observations) {
      if ((upper.count(obs.frame) > 0) == (part == 1)) subset.observations.push_back(obs);
    }
    try {
      const JointSelectionResult r = FitAndSelect(subset, o);
      const double rms = RmsSigma(r.final_fit);
      spdlog::info("split test: part {} ({} observations): rms residual {:.2f} sigma", part,
                   subset.observations.size(), rms);
      if (rms > max_rms_sigma) return false;
    } catch (const std::exception& e) {
      spdlog::info("split test: part {} could not be fitted: {}", part, e.what());
      return false;
    }
  }
  return true;
}

// The largest gap between sorted per-frame mean relative residuals splits the frames in two.
double SplitThreshold(const JointFitResult& f) {
  std::vector<double> m;
  for (const auto& fr : f.frames) m.push_back(fr.mean_relative);
  std::sort(m.begin(), m.end());
  double best_gap = -1, threshold = 0;
  for (size_t k = 1; k < m.size(); ++k) {
    if (m[k] - m[k - 1] > best_gap) {
      best_gap = m[k] - m[k - 1];
      threshold = 0.5 * (m[k] + m[k - 1]);
    }
  }
  return threshold;
}

}  // namespace

FitChecks CheckFit(const JointSelectionResult& fit, const ObservationSet& data,
                   const JointFitOptions& fit_options, const std::string& session_what,
                   const FitChecksOptions& o) {
  o.Check();
  FitChecks c;
  const JointFitResult& f = fit.final_fit;
  const double limit = o.frame_floor_multiple * fit_options.relative_noise_floor;
  std::string listed;
  for (const auto& fr : f.frames) {
    if (std::abs(fr.mean_relative) > limit) {
      c.inconsistent_frames.push_back(
          fmt::format("{} ({:+.1f}%)", fr.file, 100 * fr.mean_relative));
      listed += (listed.empty() ? "" : ", ") + c.inconsistent_frames.back();
    }
  }
  c.rms_sigma = RmsSigma(f);
  c.explains_data = c.rms_sigma <= o.max_rms_sigma;
  ParametersAtBounds(f.material, o.bound_fraction, &c.at_bounds, &c.at_domain_edges);
  if (f.frames.size() >= 4 &&
      c.inconsistent_frames.size() > o.max_inconsistent_fraction * f.frames.size() &&
      !c.explains_data &&
      BothPartsExplained(fit, data, fit_options, SplitThreshold(f), o.max_rms_sigma)) {
    throw InputError(fmt::format(
        "{}: the frames do not hold one scene: {} of {} frames differ from the best common fit "
        "by more than {:.0f}% ({}), and the two groups are each explained on their own; a moved "
        "lamp or sample, or frames of another session? Split the session or remove those frames",
        session_what, c.inconsistent_frames.size(), f.frames.size(), 100 * limit, listed));
  }
  return c;
}

std::vector<std::string> FitChecks::Messages() const {
  std::vector<std::string> m;
  if (!explains_data) {
    m.push_back(fmt::format(
        "no candidate explains these data: the selected model's residuals are {:.1f} times "
        "what pixel noise and the calibration floor explain; the parameters are the best of "
        "the candidates, not a measurement (a material outside the candidate set, or a "
        "calibration error?)",
        rms_sigma));
  }
  for (const auto& b : at_bounds) {
    m.push_back("parameter " + b +
                " sits on its bound: the data ask for a value the model cannot give; it is a "
                "limit, not a measurement");
  }
  for (const auto& e : at_domain_edges) {
    m.push_back(
        "parameter " + e +
        (explains_data
             ? " is at the edge of the model's domain, a value the model defines (not a fit "
               "bound); the fit explains the data, so the value is measured there"
             : " is at the edge of the model's domain; the fit does not explain the data, so "
               "they may ask for a value beyond it"));
  }
  if (!inconsistent_frames.empty()) {
    std::string list;
    for (const auto& s : inconsistent_frames) list += (list.empty() ? "" : ", ") + s;
    m.push_back(
        "frames that disagree with the fitted scene (moved lamp or sample, wrong "
        "exposure?): " +
        list);
  }
  return m;
}

nlohmann::json FitChecks::ToJson() const {
  return {
      {"rms_residual_over_sigma", rms_sigma},       {"explains_data", explains_data},
      {"parameters_at_bounds", at_bounds},          {"parameters_at_domain_edges", at_domain_edges},
      {"inconsistent_frames", inconsistent_frames}, {"measured", Measured()}};
}

}  // namespace gonio
