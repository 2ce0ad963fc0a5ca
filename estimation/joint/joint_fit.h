// The joint fit of a BRDF model and the unknown lamp: one Ceres problem over the model's
// parameters (per-channel albedo-like parameters with shared roughness), the lamp position
// (fixed in the board frame when the camera moves, or in the camera frame when the board
// moves) and the lamp intensity. Angles and the 1/r^2 irradiance are computed per observation
// inside the cost from the lamp estimate:
//   L = f_r(theta_i, theta_r, phi) * I * cos(theta_i) / d^2
// The board's white reference (Lambertian, known albedo A_w: L = A_w/pi * I cos(theta_i)/d^2)
// fixes I, and with it the sample's absolute albedo; without it albedo x intensity is reported
// as one quantity and the two are flagged as undetermined separately.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "common/lamp_frame.h"  // LampFrame, shared with data_synth
#include "estimation/extract/observations.h"
#include "estimation/fit/brdf_fit.h"
#include "estimation/fit/model_selection.h"
#include "estimation/fit/uncertainty.h"
#include "reflectance/angles.h"

namespace gonio {

// A nuisance of the scene, something the material does not explain but the data may show
// (docs/pipeline.md "Nuisances chosen by evidence"): left out (kNone), fitted (kFit), or chosen
// the way models are (kAuto): the model search without it, then the selected model refitted
// with it on the selection subsample; kept when the criterion (BIC, or AIC) drops by more than
// JointFitOptions::nuisance_margin, and then the models searched again with it.
enum class NuisanceTerm { kNone, kFit, kAuto };
// "none", "fit" or "auto"; InputError naming `option_name` otherwise.
NuisanceTerm ParseNuisanceTerm(const std::string& word, const std::string& option_name);
std::string ToString(NuisanceTerm term);

// The room's light (docs/pipeline.md "Ambient light"): not modelled (kNone: the data are
// lamp-only, e.g. lamp-off frames were subtracted, or the room is dark), or one constant per
// colour channel fitted on the sample (ambient radiance L_a) and one on the white reference
// (ambient irradiance E_a, reflected as A_w E_a / pi):
//   L = f_r I cos(theta_i) / d^2 + L_a        L_w = A_w / pi (I cos(theta_i) / d^2 + E_a)
// With lamp-off frames subtracted, kAuto leaves it out.
using AmbientTerm = NuisanceTerm;
AmbientTerm ParseAmbientTerm(const std::string& word, const std::string& option_name);

// How a patch observation's radiance is modelled (docs/pipeline.md "Patch average"): the BRDF
// at the patch's centre (kCentre), or its mean over the patch's area (kAverage: four points
// that match the area's second moment, Observation::patch_moment, exact for a radiance
// quadratic across the patch), or kAuto: the centre, and the average where the centre's
// bias could move a parameter by more than kPatchBiasMaxSd of its standard deviations.
enum class PatchModel { kCentre, kAverage, kAuto };
// The bound on any parameter's shift, in its standard deviations, from modelling the patch
// mean by its centre: |z_k| <= sqrt(sum_i (bias_i / sigma_i)^2) (Cauchy-Schwarz in the
// whitened least squares). A fifth of a standard deviation widens RMS z by 2% at most.
inline constexpr double kPatchBiasMaxSd = 0.2;
// "centre", "average" or "auto"; InputError naming `option_name` otherwise.
PatchModel ParsePatchModel(const std::string& word, const std::string& option_name);
std::string ToString(PatchModel model);

// Lamp starts farther than this from the board origin are refused as typos (metres).
inline constexpr double kMaxLampDistance = 1000.0;

struct JointFitOptions {
  std::vector<std::string> candidates;       // empty: AutoCandidates()
  Criterion criterion = Criterion::kBic;     // cv: K folds of held-out frames
  LampFrame lamp_frame = LampFrame::kBoard;  // where the lamp is fixed
  std::optional<Eigen::Vector3d> lamp_init;  // in lamp_frame; none: multi-start
  std::optional<double> white_albedo;        // known albedo of the white reference
  bool per_channel = true;                   // per-channel albedo-like parameters (colour data)
  AmbientTerm ambient = AmbientTerm::kAuto;  // --ambient
  // --sample-height: a correction to board.json's sample_height_m fitted with the rest (the
  // sample's points move along their pixel rays; docs/pipeline.md "Raised sample").
  NuisanceTerm sample_height = NuisanceTerm::kAuto;
  // The model search compares candidates at the patch centre; the final fit (and FitJoint)
  // follow this.
  PatchModel patch_model = PatchModel::kAuto;
  // kAuto nuisances are kept when they lower the criterion by more than this and each of their
  // terms exceeds nuisance_min_z of its standard deviations.
  double nuisance_margin = 2.0;
  double nuisance_min_z = 3.0;
  RobustLoss robust_loss = RobustLoss::kHuber;  // scale 3 sigma
  double relative_noise_floor = 0.01;           // sigma^2 = variance + (floor * L)^2
  size_t selection_max_observations = 3000;     // candidates compared on a subsample
  size_t final_max_observations = 30000;        // the selected model's final fit
  // The lamp distance is only measured through the change of irradiance (cos theta_i / d^2)
  // across the sample. Below this relative contrast, photometric calibration errors of a few
  // tenths of a percent would move it arbitrarily: its distance is reported as undetermined.
  double min_irradiance_contrast = 0.05;
  // Fit every candidate (a comparison table, `--models all`) instead of the staged search,
  // which stops at the first parameter count whose best model explains the data to the noise.
  bool exhaustive = false;
  // The staged search goes on at least to the stage with this many material parameters, even
  // when a simpler stage explains the data to the noise. A nuisance term can mimic part of a
  // material's shape (a height correction gives a Lambertian fit the view dependence of a rough
  // one, docs/pipeline.md "Raised sample"), so a search with the terms on goes at least as far
  // as the search without them did, and the criterion, not the stopping rule, decides.
  // FitAndSelect sets it for its search again with kept terms and, with a term forced on, from
  // a search without it first; DropNuisances for its search with one of two kept terms left.
  size_t search_through_params = 0;
  // Fit van-ginneken and oren-nayar-vcavity through their smooth tables
  // (estimation/joint/tabulated_models.h): same model within the tabulation error, many times
  // faster.
  bool tabulated_models = true;
  int cv_folds = 4;
  int max_iterations = 100;
  // A solve stops once a step lowers the cost by less than this fraction of it (Ceres'
  // function tolerance). The model search's fits use a looser one derived from the criterion's
  // margin (joint_selection.cc SearchTolerance); the reported fit uses this one.
  double function_tolerance = 1e-10;
  // Set by the model search only (joint_selection.cc "Stopping a candidate that cannot win"):
  // the lowest weighted sum of squares of the search's earlier stages. A candidate's solve
  // stops once it cannot get below it within its iterations; infinite (never) elsewhere.
  double search_weighted_ssr_to_beat = INFINITY;
  int threads = 0;
  UncertaintyOptions uncertainty;
  void Check() const;
};

struct FrameResidual {
  int frame = 0;
  std::string file;
  size_t n = 0;
  double rms_sigma = 0;      // rms of residual / sigma
  double mean_relative = 0;  // mean of (model - measured) / measured
};

// A nuisance term --ambient auto / --sample-height auto left out although the data could not
// exclude it (nuisance_choice.cc NoteEffectsOnTheLamp): its trial beside the terms kept stood
// more than 2 of its final standard deviations out and moved the lamp by more than kShiftInSd
// of the lamp's, or it was kept and then dropped after moving the lamp (or the material) that
// far (UnresolvedAfterDrop), or the terms the selection kept were all dropped and, fitted
// alone, it moved either that far (JointSelectionResult::unresolved_if_kept_term_dropped),
// so the result depends on it (pipeline/checks.cc warns). The calibration's
// part of the lamp's bar is known only after the final fit: AddCalibrationUncertainty
// (calibration_error.h) judges the shift again against the widened bar and drops a shift the bar
// covers.
struct JointFitResult;

struct UnresolvedNuisance {
  static constexpr double kShiftInSd = 3.0;
  enum class Term { kAmbient, kHeight };
  Term term = Term::kAmbient;
  double z = 0;  // the term's |value| / sd at the final size
  Eigen::Vector3d lamp_shift = Eigen::Vector3d::Zero();  // how far fitting it moved the lamp
  // The largest shift in the standard deviations of what moved: the lamp's worst axis, or the
  // material parameter `moved_param` of `param_shift`.
  double shift_in_sd = 0;
  // After a drop (UnresolvedAfterDrop), how far the fit that kept the term put each material
  // parameter from the fit without it, by name (kept - without): a dropped term can move the
  // material more than the lamp (a glossy sample 4 mm above the board, its height kept at z 5.5
  // on the noise's bar and dropped at z 2.4 on the calibration's: sigma 27 bars off, the lamp
  // within 1.2; docs/pipeline.md "Raised sample").
  std::vector<std::pair<std::string, double>> param_shift = {};
  std::string moved_param = {};  // empty: the lamp moved most
  // Judged alone against the fit without terms after the terms the selection kept were all
  // dropped (JointSelectionResult::unresolved_if_kept_term_dropped): `z` is the term's fitted
  // alone; kept_beside_the_other: the selection had kept it with the other term, else the other
  // instead of it.
  bool beside_a_dropped_term = false;
  bool kept_beside_the_other = false;
  // Left out beside the terms kept although it stood beyond nuisance_min_z: the criterion did
  // not prefer the fit with it by nuisance_margin (NoteEffectsOnTheLamp). Else it stood within.
  bool lost_by_the_criterion = false;

  // shift_in_sd and moved_param against `f`'s standard deviations: the lamp's (worst axis) and
  // those of the material parameters of param_shift (by name, where `f` has them). True when
  // the shift is then beyond kShiftInSd: the term stays unresolved.
  bool JudgeAgainst(const JointFitResult& f);
  // param_shift: each parameter of `with` less the same one of `without` (the same model).
  void SetParamShift(const BrdfFitResult& with, const BrdfFitResult& without);

  // |shift| over `lamp_sd` on the worst axis (axes with sd 0 left out).
  static double ShiftInSd(const Eigen::Vector3d& shift, const Eigen::Vector3d& lamp_sd) {
    double in_sd = 0;
    for (int k = 0; k < 3; ++k) {
      if (lamp_sd[k] > 0) in_sd = std::max(in_sd, std::abs(shift[k]) / lamp_sd[k]);
    }
    return in_sd;
  }
};

// How far a nuisance term --ambient auto / --sample-height auto could move the lamp if it
// were fitted: per axis, the lamp's shift per standard deviation of the term at the final size,
// sqrt(sd_free^2 - sd_fixed^2) with sd_free the lamp's statistical standard deviation in the
// trial that fitted the term beside the terms kept (ChooseNuisances) and sd_fixed the one
// without it. For a linear model that is |cov(lamp, term)| / sd(term): the part of the lamp's
// bar the term adds when free. A term the data leave out within its bar is an assumption, not
// a finding: room light at 2 of its standard deviations is what they cannot exclude, and where
// the lamp and the term trade strongly (room light at 0.5 % of the lamp: the term at z 0.2,
// the lamp 5 bars off; docs/pipeline.md "Ambient light") the result rests on it
// (pipeline/checks.h AssumedAbsentNuisanceNotes).
struct NuisanceSensitivity {
  UnresolvedNuisance::Term term = UnresolvedNuisance::Term::kAmbient;
  Eigen::Vector3d lamp_per_term_sd = Eigen::Vector3d::Zero();
};

struct JointFitResult {
  BrdfFitResult material;  // grey or channel-0 parameters, their stddev, metrics
  // The parameters fitted per colour channel (ParamInfo::per_channel: albedo-like ones) and,
  // per channel, their values in that order (fit.json: params_per_channel).
  std::vector<std::string> per_channel_param_names;
  std::vector<std::vector<double>> per_channel_params;
  LampFrame lamp_frame = LampFrame::kBoard;
  Eigen::Vector3d lamp_position = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> lamp_stddev;
  double intensity = 1.0;
  std::optional<double> intensity_stddev;
  bool absolute = false;                       // a white reference fixed the intensity
  std::vector<std::string> undetermined_lamp;  // "lamp_x", "intensity", ...
  // Shared material parameters undetermined because they move along an unseen direction that
  // the albedo-like ones or the intensity bound (UncertaintyResult::moves_with): without a white
  // reference, the pitted models' coverage.
  std::vector<std::string> moves_with_albedo;
  // The ambient terms per colour channel (AmbientTerm::kFit; empty otherwise): the sample's
  // ambient radiance and the ambient irradiance on the white reference (empty without a
  // white reference), with their standard deviations; lamp_irradiance: the lamp's mean
  // irradiance I cos(theta_i) / d^2 over the sample, which the irradiance is a fraction of.
  AmbientTerm ambient = AmbientTerm::kNone;
  std::vector<double> ambient_sample, ambient_irradiance;
  std::vector<std::optional<double>> ambient_sample_stddev, ambient_irradiance_stddev;
  double lamp_irradiance = 0;
  std::string ambient_reason;  // kAuto: why the terms were kept or left out
  // --sample-height fit (or auto, kept): the fitted correction to board.json's sample height
  // (metres, > 0: the top stands further out) and its standard deviation.
  std::optional<double> sample_height_offset, sample_height_offset_stddev;
  std::string sample_height_reason;  // kAuto: why the correction was kept or left out
  // kAuto: see UnresolvedNuisance; at most one per term (the one that moved most), each its own
  // warning (pipeline/checks.cc): a user who settles one should not meet the other only on the
  // next run.
  std::vector<UnresolvedNuisance> unresolved_nuisances;
  // kAuto: every term's trial, whether the term was kept or not (NuisanceSensitivity).
  std::vector<NuisanceSensitivity> nuisance_sensitivity;
  // The patch model the fit used (kCentre or kAverage) and, when it was chosen (kAuto), the
  // bound on the centre's bias in standard deviations that chose it.
  PatchModel patch_model = PatchModel::kCentre;
  std::optional<double> patch_bias_bound_sd;
  size_t lamp_off_frames = 0;  // frames whose lamp-off radiance extraction subtracted
  double fit_s = 0;  // wall time of this fit's solves (a search candidate's: docs/pipeline.md)
  std::vector<FrameResidual> frames;
  std::vector<std::string> warnings;
  size_t n_observations = 0;

  nlohmann::json ToJson() const;
  nlohmann::json AmbientJson() const;  // fit.json "ambient" (docs/formats.md)
  // Without a white reference (!absolute), what the reports say: albedo-like values are
  // relative, and those of moves_with_albedo (the pitted models' coverage, through the pits'
  // interreflection: estimation/fit/uncertainty.h null_excursion_sd) with them, which a white
  // reference of known albedo fixes. "" with one.
  std::string RelativeNote() const;
};

struct JointSelectionResult {
  ModelSelectionResult selection;    // candidates' material results and the rule's reason
  std::vector<JointFitResult> fits;  // same order as selection.candidates
  JointFitResult final_fit;          // the selected model refitted on every observation
  // The search before the kAuto nuisance terms final_fit keeps (null when it keeps none), for
  // DropNuisances: leaving a term out restores it instead of searching again.
  std::shared_ptr<const JointSelectionResult> without_nuisances;
  // When final_fit keeps kAuto terms: a term fitted alone against the fit without terms (the
  // other one when one is kept, either when both are) that stood more than 2 of its final
  // standard deviations out and moved the lamp or the material beyond kShiftInSd. If a drop
  // (DropUnsupportedNuisances, DropNuisances) leaves the fit without any term, the criterion no
  // longer chose against this one and the result depends on it: it is then unresolved
  // (nuisance_choice.cc UnkeptBesideNone).
  std::optional<UnresolvedNuisance> unresolved_if_kept_term_dropped;
  std::string Report() const;
  nlohmann::json ToJson() const;
};

// The angles and irradiance factor cos(theta_i)/d^2 of an observation under a fitted lamp, at
// the fitted sample height (the same computation the cost uses). False when the lamp is behind
// the sample.
bool ObservationGeometry(const Observation& o, const JointFitResult& fit, Angles<double>* angles,
                         double* irradiance_factor);

// One model, from a given lamp start (in options.lamp_frame). Its held-out frame RMS
// (material.cv_rms, options.cv_folds refits) only under Criterion::kCv, which reads it.
JointFitResult FitJoint(const std::string& model, const ObservationSet& data,
                        const Eigen::Vector3d& lamp_start, const JointFitOptions& options);

// Lamp starting points: options.lamp_init, else a deterministic set over the hemisphere in
// front of the board, screened with a Lambertian fit; returns the best.
Eigen::Vector3d InitialLamp(const ObservationSet& data, const JointFitOptions& options);

// `options` with the nuisances as `fit` has them (kAuto resolved to kFit or kNone): what a refit
// of the same model must use (the calibration error's refits, the split test).
JointFitOptions WithChosenNuisances(const JointFitOptions& options, const JointFitResult& fit);

// The radiance `fit` predicts for observation `o` in `channel`: the material under the lamp,
// plus the fitted ambient term, at the fitted sample height (the white reference: its known
// albedo `white_albedo`). NaN when the lamp is behind the point.
double PredictedRadiance(const Observation& o, int channel, const JointFitResult& fit,
                         double white_albedo);

// |value| / standard deviation of a fit's ambient terms (the largest over the sample's radiance
// and the white reference's irradiance, per channel) or of its height correction; 0 when
// undetermined or absent.
double NuisanceZ(const JointFitResult& f, bool ambient_term);

// The nuisance terms --ambient auto / --sample-height auto (`requested`) kept in `f`, and which
// of them stand within nuisance_min_z of their standard deviations there: FitAndSelect judges
// them on the final fit's noise bar, gonio run again on the bar the calibration's part widened
// (pipeline/run.cc).
struct NuisanceDrop {
  bool ambient_kept = false, height_kept = false;
  bool ambient = false, height = false;  // kept and within their bars: to be left out
  double z_ambient = 0, z_height = 0;
  bool Any() const { return ambient || height; }
  std::string Named() const;  // "ambient (z 2.39)", "height (z ...)" or both joined by "and"
};
NuisanceDrop NuisancesWithinTheirBars(const JointFitOptions& requested, const JointFitResult& f);

// After `drop` left every kept term out: the term as unresolved when the fit that kept it
// (`kept`) put the lamp more than kShiftInSd of the lamp's standard deviations (`without`'s,
// worst axis) from where the fit without it (`without`) puts it, or a material parameter of the
// same model more than kShiftInSd of its own. The term stood out on the
// noise's bar and sits within nuisance_min_z of a wider one (all observations, or the
// calibration's part added), so the data neither keep nor exclude it, and the lamp depends on
// it (docs/pipeline.md "Ambient light": room light at 1 % of the lamp kept on the selection's
// subsample and dropped at z 2.2-2.6 on all observations left the lamp 11 bars off).
std::optional<UnresolvedNuisance> UnresolvedAfterDrop(const NuisanceDrop& drop,
                                                      const JointFitResult& kept,
                                                      const JointFitResult& without);

// `candidate` into `per_term` (JointFitResult::unresolved_nuisances) in place of the entry of
// its term when it moved more (shift_in_sd), or added when its term has none.
void KeepTheWorseOfItsTerm(const std::optional<UnresolvedNuisance>& candidate,
                           std::vector<UnresolvedNuisance>* per_term);

// Every candidate (on a subsample), the simplest adequate one chosen, then refitted on all.
// InputError on unusable data (no sample observations, one frame with --criterion cv, ...).
JointSelectionResult FitAndSelect(const ObservationSet& data, const JointFitOptions& options);

// `selection` (FitAndSelect's on `data` with `options`) with the terms `drop` names left out:
// when no kept term is left, the search without nuisances (the one FitAndSelect made first) is
// restored and its selected model refitted on all, without searching the models again; when
// one of two is left, the models are searched again with it on. gonio run calls it when the bar
// the calibration's part widened holds a term (pipeline/run.cc).
JointSelectionResult DropNuisances(const ObservationSet& data, const JointFitOptions& options,
                                   const NuisanceDrop& drop, const JointSelectionResult& selection);

}  // namespace gonio
