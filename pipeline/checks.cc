#include "pipeline/checks.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/math.h"
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
  r.options = WithChosenNuisances(fit_options, r.fit.final_fit);
  r.checks = CheckFit(r.fit, data, r.options, what, options);
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
  structure.Check();
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
  o.lamp_init = std::nullopt;
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

// How far rival k's own fit puts the results it shares with the selected model (their fits on
// the selection's subsample), in the final fit's standard deviations: "sigma 2.3 sd", "lamp
// 1.4 sd" for those beyond one.
std::vector<std::string> ResultsARivalMoves(const JointSelectionResult& fit, int k) {
  const JointFitResult &chosen = fit.fits[fit.selection.selected], &rival = fit.fits[k];
  const BrdfFitResult& final_material = fit.final_fit.material;
  std::vector<std::string> moved;
  for (size_t i = 0; i < final_material.param_names.size(); ++i) {
    const auto& names = rival.material.param_names;
    const size_t j =
        std::find(names.begin(), names.end(), final_material.param_names[i]) - names.begin();
    if (j >= rival.material.params.size() || i >= chosen.material.params.size() ||
        i >= final_material.stddev.size() || !final_material.stddev[i] ||
        !(*final_material.stddev[i] > 0)) {
      continue;
    }
    const double apart =
        std::abs(rival.material.params[j] - chosen.material.params[i]) / *final_material.stddev[i];
    if (apart > 1) moved.push_back(fmt::format("{} {:.1f} sd", names[j], apart));
  }
  if (const auto& sd = fit.final_fit.lamp_stddev; sd && (sd->array() > 0).all()) {
    const double apart =
        ((rival.lamp_position - chosen.lamp_position).array() / sd->array()).abs().maxCoeff();
    if (apart > 1) moved.push_back(fmt::format("lamp {:.1f} sd", apart));
  }
  return moved;
}

// The selection's rivals (ModelSelectionResult::rivals) whose own fit moves a result by more
// than one standard deviation: a choice the data leave open and that changes the answer
// ("oren-nayar (bic +1.77): lamp 2.1 sd"). A rival that gives the same values is no such choice
// (li-torrance:dd and :coh+dd on a rough sample).
std::vector<std::string> RivalsThatMoveResults(const JointSelectionResult& fit) {
  std::vector<std::string> out;
  const ModelSelectionResult& sel = fit.selection;
  if (sel.selected < 0 || fit.fits.size() != sel.candidates.size()) return out;
  for (int k : sel.rivals) {
    const std::vector<std::string> moved = ResultsARivalMoves(fit, k);
    if (!moved.empty()) {
      out.push_back(fmt::format("{}: {}", sel.RivalText(k), fmt::join(moved, ", ")));
    }
  }
  return out;
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
  c.rival_models = RivalsThatMoveResults(fit);
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

std::string ToString(WarningCause cause) {
  switch (cause) {
    case WarningCause::kFrameSkipped:
      return "frame-skipped";
    case WarningCause::kModelChoice:
      return "model-choice";
    case WarningCause::kReprojection:
      return "reprojection";
    case WarningCause::kFit:
      return "fit";
    case WarningCause::kNotExplained:
      return "not-explained";
    case WarningCause::kMaps:
      return "maps";
    case WarningCause::kAtBound:
      return "at-bound";
    case WarningCause::kInconsistentFrames:
      return "inconsistent-frames";
    case WarningCause::kResidualIrradiance:
      return "residual-irradiance";
    case WarningCause::kResidualView:
      return "residual-view";
    case WarningCause::kResidualPosition:
      return "residual-position";
    case WarningCause::kAmbientLight:
      return "ambient-light";
    case WarningCause::kSampleHeight:
      return "sample-height";
    case WarningCause::kResponse:
      return "response";
  }
  return "unknown";
}

nlohmann::json RunWarning::ToJson() const {
  return {{"cause", ToString(cause)}, {"message", message}, {"touches", touches}};
}

std::vector<std::string> AllResults(const JointFitResult& fit) {
  std::vector<std::string> out = fit.material.param_names;
  out.push_back("lamp");
  out.push_back("intensity");
  return out;
}

nlohmann::json TouchedResults(const std::vector<RunWarning>& warnings) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& w : warnings) {
    for (const auto& t : w.touches) {
      if (!j.contains(t)) j[t] = nlohmann::json::array();
      const std::string cause = ToString(w.cause);
      if (std::find(j[t].begin(), j[t].end(), cause) == j[t].end()) j[t].push_back(cause);
    }
  }
  return j;
}

namespace {

// What to try when the residuals follow an axis (docs/pipeline.md "Residual structure").
std::string StructureAdvice(ResidualAxis axis) {
  switch (axis) {
    case ResidualAxis::kIrradiance:
      return "room light the fit does not model (shoot lamp-off frames, or --ambient fit), or a "
             "response off in its dark or bright end (a sweep in third stops)";
    case ResidualAxis::kView:
      return "the sample standing above the plane board.json gives (measure its thickness into "
             "sample_height_m, or --sample-height fit), or a material the candidates do not "
             "hold (--models all)";
    case ResidualAxis::kPosition:
      return "the vignetting (calibrate it from a flat field, or from more poses of the board)";
  }
  return "";
}

void AddStructureWarnings(const ResidualStructure& s, const std::vector<std::string>& all,
                          std::vector<RunWarning>* m) {
  const WarningCause causes[] = {WarningCause::kResidualIrradiance, WarningCause::kResidualView,
                                 WarningCause::kResidualPosition};
  const char* units[] = {"x the median irradiance", "deg", "half-diagonals from the centre"};
  for (const auto& t : s.trends) {
    if (!t.structured) continue;
    const auto lo = std::min_element(t.mean.begin(), t.mean.end());
    const auto hi = std::max_element(t.mean.begin(), t.mean.end());
    const int a = static_cast<int>(t.axis);
    m->push_back({causes[a],
                  fmt::format("the residuals follow the {}: the model is {:+.1f}% off at {:.2g} {} "
                              "and {:+.1f}% at {:.2g}, beyond the {:.1f}% the calibration's "
                              "accuracy allows; try: {}",
                              ToString(t.axis), 100 * *lo, t.centre[lo - t.mean.begin()], units[a],
                              100 * *hi, t.centre[hi - t.mean.begin()], 100 * t.threshold,
                              StructureAdvice(t.axis)),
                  all});
  }
}

// Room light lights the white reference as it lights the sample (docs/pipeline.md "Ambient
// light"): a sample constant L_a implies a white irradiance E_a = pi L_a / albedo (Lambertian;
// rho_dh for the others, approximated by the albedo). The kept constant is not room light when,
// in some channel, it is negative beyond 3 of its standard deviations or the white's measured
// E_a falls short of the implied one by more than 3 standard deviations of their difference.
// A white whose E_a is too uncertain to tell says nothing either way.
bool AmbientIsNotRoomLight(const JointFitResult& f) {
  const auto& names = f.per_channel_param_names;
  const auto albedo_at = std::find(names.begin(), names.end(), "albedo");
  if (albedo_at == names.end()) return false;
  const size_t k = albedo_at - names.begin();
  for (size_t c = 0; c < f.ambient_sample.size(); ++c) {
    const auto sd_l =
        c < f.ambient_sample_stddev.size() ? f.ambient_sample_stddev[c] : std::optional<double>();
    if (!sd_l) continue;
    const double l_a = f.ambient_sample[c];
    if (l_a < -3 * *sd_l) return true;
    if (c >= f.ambient_irradiance.size() || c >= f.ambient_irradiance_stddev.size() ||
        !f.ambient_irradiance_stddev[c] || c >= f.per_channel_params.size() ||
        k >= f.per_channel_params[c].size() || !(f.per_channel_params[c][k] > 0)) {
      continue;
    }
    const double albedo = f.per_channel_params[c][k];
    const double implied = kPi * l_a / albedo, sd_implied = kPi * *sd_l / albedo;
    const double sd = std::hypot(*f.ambient_irradiance_stddev[c], sd_implied);
    if (f.ambient_irradiance[c] + 3 * sd < implied) return true;
  }
  return false;
}

// The warning for a term the data neither keep nor exclude (UnresolvedNuisance): how far it
// stood out, why it was not kept, what it moves and what settles it.
std::string UnresolvedMessage(const UnresolvedNuisance& u, const std::string& response_remedy) {
  const bool ambient = u.term == UnresolvedNuisance::Term::kAmbient;
  const std::string other = ambient ? "a sample height" : "room light";
  const std::string why =
      !u.beside_a_dropped_term
          ? (u.lost_by_the_criterion
                 ? "enough to keep it, but the criterion did not prefer the fit with it"
                 : "too few to keep it")
      : u.kept_beside_the_other
          ? "the selection kept it with " + other + ", and the final bars then left both out"
          : "the selection kept " + other + " instead, which the final bars then left out";
  const std::string moves =
      u.moved_param.empty()
          ? fmt::format("the lamp by {:.1f} mm, {:.0f} times the lamp's standard deviation",
                        1e3 * u.lamp_shift.norm(), u.shift_in_sd)
          : fmt::format("{} by {:.0f} times its standard deviation (the lamp by {:.1f} mm)",
                        u.moved_param, u.shift_in_sd, 1e3 * u.lamp_shift.norm());
  // A calibration error bends the radiance the way either term does (docs/pipeline.md "Coverage
  // under nuisances": on whole-stop sweeps in a dark room with the sample flat, 7 of 20 runs
  // had a term that stood 8-29 deviations out alone), so each warning gives both readings.
  const std::string bend =
      "the response's error bends the radiance this way (narrowed by " +
      (response_remedy.empty() ? std::string("a finer sweep or RAW") : response_remedy) + ")";
  const std::string settle =
      ambient ? "lamp-off frames (session.json lamp_off) settle it; if the room was dark, " + bend
              : "measure the sample's thickness into board.json sample_height_m; if it lies flat "
                "on the board, " +
                    bend;
  return fmt::format(
      "{} cannot be excluded: fitted{}, it stands {:.1f} standard deviations out "
      "({}) and moves {}; {}",
      ambient ? "room light" : "a sample height off board.json's",
      u.beside_a_dropped_term ? " alone" : "", u.z, why, moves, settle);
}

// Nuisances that --ambient auto / --sample-height auto found and fitted: the user did not
// declare them, and each costs precision (docs/pipeline.md "Nuisances chosen by evidence").
void AddNuisanceWarnings(const JointFitResult& f, const std::vector<std::string>& all,
                         const std::string& response_remedy, std::vector<RunWarning>* m) {
  if (f.ambient == AmbientTerm::kFit && !f.ambient_reason.empty()) {
    std::string size;
    if (!f.ambient_irradiance.empty() && f.lamp_irradiance > 0) {
      const auto& sd = f.ambient_irradiance_stddev;
      size = fmt::format(" at {:.1f}%{} of the lamp's irradiance on the sample",
                         100 * f.ambient_irradiance[0] / f.lamp_irradiance,
                         !sd.empty() && sd[0]
                             ? fmt::format(" +- {:.1f}%", 100 * *sd[0] / f.lamp_irradiance)
                             : std::string());
    }
    if (AmbientIsNotRoomLight(f)) {
      m->push_back({WarningCause::kNotExplained,
                    "the sample shows a constant radiance that room light cannot give (negative, "
                    "or more than the white reference's room light" +
                        size +
                        " allows): the constant the selection kept stands for something the "
                        "model does not hold (the material model's shape, the response's dark "
                        "end), and the values and error bars may be off by it; lamp-off frames "
                        "(session.json lamp_off) would show whether the room was dark",
                    all});
    } else {
      m->push_back({WarningCause::kAmbientLight,
                    "the data show room light" + size +
                        ", fitted as a constant: it trades against the lamp's distance and the "
                        "material's shape, so every error bar is wider; lamp-off frames "
                        "(session.json lamp_off) remove it exactly",
                    all});
    }
  }
  for (const UnresolvedNuisance& u : f.unresolved_nuisances) {
    m->push_back({u.term == UnresolvedNuisance::Term::kAmbient ? WarningCause::kAmbientLight
                                                               : WarningCause::kSampleHeight,
                  UnresolvedMessage(u, response_remedy), all});
  }
  if (f.sample_height_offset && !f.sample_height_reason.empty()) {
    m->push_back({WarningCause::kSampleHeight,
                  fmt::format("the data place the sample's surface {:+.2f} mm{} from the plane "
                              "board.json gives, fitted: measure the sample's thickness and "
                              "write it into board.json sample_height_m",
                              1e3 * *f.sample_height_offset,
                              f.sample_height_offset_stddev
                                  ? fmt::format(" +- {:.2f}", 1e3 * *f.sample_height_offset_stddev)
                                  : std::string()),
                  all});
  }
}

}  // namespace

std::vector<RunWarning> FitChecks::Warnings(const JointFitResult& fit,
                                            const std::string& response_remedy) const {
  std::vector<RunWarning> m;
  const std::vector<std::string> all = AllResults(fit);
  if (!explains_data) {
    m.push_back(
        {WarningCause::kNotExplained,
         fmt::format(
             "no candidate explains these data: the selected model's residuals are {:.1f} times "
             "what pixel noise and the calibration floor explain; the parameters are the best of "
             "the candidates, not a measurement (a material outside the candidate set, a "
             "sample that is not one material: gonio maps, or a calibration error?)",
             rms_sigma),
         all});
  }
  for (const auto& b : at_bounds) {
    // "sigma (upper bound ...)": the parameter's name leads.
    m.push_back({WarningCause::kAtBound,
                 "parameter " + b +
                     " sits on its bound: the data ask for a value the model cannot give; it is "
                     "a limit, not a measurement",
                 {b.substr(0, b.find(' '))}});
  }
  for (const auto& e : at_domain_edges) {
    m.push_back(
        {WarningCause::kAtBound,
         "parameter " + e +
             (explains_data
                  ? " is at the edge of the model's domain, a value the model defines (not a fit "
                    "bound); the fit explains the data, so the value is measured there"
                  : " is at the edge of the model's domain; the fit does not explain the data, "
                    "so they may ask for a value beyond it"),
         {e.substr(0, e.find(' '))}});
  }
  if (!inconsistent_frames.empty()) {
    std::string list;
    for (const auto& s : inconsistent_frames) list += (list.empty() ? "" : ", ") + s;
    m.push_back({WarningCause::kInconsistentFrames,
                 "frames that disagree with the fitted scene (moved lamp or sample, wrong "
                 "exposure?): " +
                     list,
                 all});
  }
  if (!rival_models.empty()) {
    // Same-count rivals within the margin (docs/pipeline.md "Checks"): the values are the
    // selected model's; a rival's parameters mean other things, and the lamp moves with it.
    m.push_back({WarningCause::kModelChoice,
                 fmt::format("the data do not tell {} from {}: as many parameters and within the "
                             "criterion's margin, and the rival's fit moves these results; every "
                             "result is the selected model's (fit each with --models to compare, "
                             "or add views where they disagree)",
                             fit.material.model, fmt::join(rival_models, ", ")),
                 all});
  }
  AddStructureWarnings(structure, all, &m);
  AddNuisanceWarnings(fit, all, response_remedy, &m);
  return m;
}

nlohmann::json FitChecks::ToJson() const {
  return {{"rms_residual_over_sigma", rms_sigma},
          {"explains_data", explains_data},
          {"parameters_at_bounds", at_bounds},
          {"parameters_at_domain_edges", at_domain_edges},
          {"inconsistent_frames", inconsistent_frames},
          {"residual_structure", structure.ToJson()},
          {"measured", Measured()}};
}

// Bars sized by the floor and errors by the residuals read RMS z below the coverage target's 0.6
// (docs/pipeline.md "Coverage of the error bars") once the floor is kFloorOverResiduals times the
// residuals' relative scatter. Measured: on 12 noise seeds of one pitted capture with the
// renderer's calibrations (no stated accuracy) the default 1 % against residuals of 0.28 % gave
// values spread 0.20-0.29 of their bars; the note says 3.6 (docs/pipeline.md "The user's own
// calibrations").
std::optional<std::string> AssumedNoiseFloorNote(double floor, NoiseFloorSource source,
                                                 double residual_rel_rms) {
  if (source == NoiseFloorSource::kCalibration) return std::nullopt;
  const bool by_default = source == NoiseFloorSource::kDefault;
  std::string note = fmt::format(
      "the calibration's relative error is taken as {:.2f}% ({}); every error bar rests on it",
      100 * floor,
      by_default ? "the default: no calibration stated its accuracy" : "--noise-floor");
  if (std::isfinite(residual_rel_rms) && residual_rel_rms > 0 &&
      floor > kFloorOverResiduals * residual_rel_rms) {
    note += fmt::format(
        ", and the residuals scatter {:.2f}%, so the bars may be up to {:.1f} times wider than "
        "the data need",
        100 * residual_rel_rms, floor / residual_rel_rms);
  }
  if (by_default) {
    note +=
        "; photometric.json's relative_accuracy (written by `gonio photometric vignette "
        "--photometric-out`, docs/photometric.md) or --noise-floor states it";
  }
  return note;
}

std::vector<std::string> AssumedAbsentNuisanceNotes(const JointFitResult& fit) {
  std::vector<std::string> notes;
  if (!fit.lamp_stddev) return notes;
  for (const NuisanceSensitivity& n : fit.nuisance_sensitivity) {
    const bool ambient = n.term == UnresolvedNuisance::Term::kAmbient;
    const bool kept = ambient ? !fit.ambient_sample.empty() : fit.sample_height_offset.has_value();
    const bool warned =
        std::any_of(fit.unresolved_nuisances.begin(), fit.unresolved_nuisances.end(),
                    [&](const UnresolvedNuisance& u) { return u.term == n.term; });
    const Eigen::Vector3d shift = kAssumedAbsentSd * n.lamp_per_term_sd;
    const double in_sd = UnresolvedNuisance::ShiftInSd(shift, *fit.lamp_stddev);
    if (kept || warned || !(in_sd > 1.0)) continue;
    notes.push_back(fmt::format(
        "{}: the data hold it within its error bar, but cannot exclude it at {:g} of its standard "
        "deviations, which would move the lamp by up to {:.1f} mm, {:.1f} times its standard "
        "deviation (the lamp's bar holds it at zero); {}",
        ambient ? "no room light" : "the sample's top where board.json sample_height_m puts it",
        kAssumedAbsentSd, 1e3 * shift.norm(), in_sd,
        ambient ? "lamp-off frames (session.json lamp_off) remove the doubt; --ambient fit "
                  "widens the bars to hold it"
                : "the sample's measured thickness in board.json sample_height_m removes the "
                  "doubt; --sample-height fit widens the bars to hold it"));
  }
  return notes;
}

}  // namespace gonio
