// `gonio maps` (and `gonio run --maps`) as a library: per-texel albedo, normal, height,
// roughness and material maps of a textured sample with per-texel standard deviations
// (docs/maps.md).
//
//   LoadMapsSessionInputs  session.json, board, camera model, photometric calibration
//   MapsFromSession        frames -> board poses (unless given) -> the lamp from the white
//                          reference and a uniform fit
//                          (unless --lamp) -> texel samples -> SolveMaps
//   MapsFromRectified      MaterialGAN's rectified layout (NN.png, camera_pos.txt,
//                          light_pos.txt, image_size.txt) -> texel samples -> SolveMaps
//   SolveMaps              the maps for each roughness hypothesis (one for the sample, one per
//                          material cluster, one per texel), chosen by BIC; the height; the
//                          held-out view's prediction
//   WriteMapsOutputs       TIFF maps, PNG previews, maps.json, per-view re-renders and
//                          residuals, report/: written into a temporary folder renamed as a
//                          whole
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/geometry/board.h"
#include "calib/geometry/locate.h"
#include "calib/photometry/photometric.h"
#include "common/camera_model.h"
#include "common/session.h"
#include "estimation/joint/calibration_error.h"
#include "estimation/joint/joint_fit.h"
#include "estimation/maps/clusters.h"
#include "estimation/maps/incidental_bias.h"
#include "estimation/maps/registration.h"
#include "estimation/maps/texel_data.h"
#include "estimation/maps/texel_solver.h"

namespace gonio {

// --roughness: chosen by evidence (BIC), or forced.
enum class RoughnessChoice { kAuto, kSample, kClusters, kTexel };
// "auto", "sample", "clusters", "texel"; InputError naming `option` otherwise.
RoughnessChoice ParseRoughnessChoice(const std::string& word, const std::string& option);

struct MapsOptions {
  // --model; none: oren-nayar when a white reference of known albedo makes the albedo
  // absolute, else oren-nayar-qualitative (linear in the albedo, so a relative albedo is
  // consistent: oren-nayar's interreflection term would see the albedo's unknown scale).
  std::optional<MapsModel> model;
  MapsModel ResolvedModel(bool absolute) const {
    return model ? *model : absolute ? MapsModel::kOrenNayar : MapsModel::kOrenNayarQualitative;
  }
  TexelSamplingOptions sampling;
  TexelSolveOptions solve;  // its model is set from ResolvedModel
  ClusterOptions clusters;
  RoughnessChoice roughness = RoughnessChoice::kAuto;
  // --lamp: the lamp's position in lamp_frame, held fixed; none: placed by the board's white
  // reference (else a uniform fit of the session), refined with the maps.
  std::optional<Eigen::Vector3d> lamp;
  LampFrame lamp_frame = LampFrame::kBoard;
  std::optional<double> white_albedo;  // known albedo of the white reference
  // Relative error added to every radiance's noise (the calibration's uncertainty, e.g.
  // photometric.json's relative_accuracy; docs/maps.md "Noise").
  double relative_noise_floor = 0;
  std::optional<int> hold_out;  // a view fitted without and predicted (rectified input)
  // Refits of the uniform fit under perturbed calibrations (estimation/joint/calibration_error.h)
  // when photometric.json gives its accuracy: their spread of the roughness, the albedo and the
  // lamp is added to the maps' standard deviations (docs/maps.md "Calibration error"); 0: off.
  CalibrationPropagationOptions calibration_error;
  // Rounds of registering the views against the maps (estimation/maps/registration.h); 0: off.
  // Grids with more texels than 1.5 times this: the lamp, registration, noise model, clusters
  // and roughness hypothesis are found on blocks of about this many texels, the chosen maps
  // then fitted on all (docs/maps.md "Speed").
  size_t search_texels = 25000;
  // The shared roughness's incidental bias, measured and subtracted (incidental_bias.h).
  IncidentalBiasOptions incidental_bias;
  // One round brings the noise-free textured preset at 640x480 from 0.52% / 1.10 deg (albedo /
  // normal, RMS) to 0.15% / 0.13 deg; with the renderer's own poses 0.03% / 0.05 deg.
  int registration_rounds = 1;
  // The selected maps' chi2 per residual above which they do not explain the views: warned,
  // and the maps and their standard deviations are not a measurement (docs/maps.md "Checks").
  // Measured: 0.86 on the one-material textured preset, 0.86 on textured-3mat (3.8 when its
  // edge texels and a lamp placed with one roughness for three materials were in the figure).
  double max_chi2_per_residual = 2.0;
  int threads = 0;
  void Check() const;  // InputError naming the option
};

// One roughness hypothesis, fitted.
struct MapsCandidate {
  RoughnessMode mode = RoughnessMode::kSample;
  int clusters = 1;
  double chi2 = 0, bic = 0;
  size_t parameters = 0, residuals = 0;
  std::vector<double> cluster_roughness, cluster_roughness_sd;
  // Per shared value (roughness per cluster, lamp x y z, intensity, as fitted): how far the
  // views' scatter widened its standard deviation (TexelFit::shared_sd_factor).
  std::vector<double> shared_sd_factor;
  double seconds = 0;
};

struct ViewFit {
  std::string name;
  int view = 0;
  double registration_rms_m = 0;  // the registration's displacement, RMS over the texels
  size_t texels = 0;
  double rms_z = 0;         // RMS of (predicted - measured) / sigma
  double relative_rms = 0;  // sqrt(sum (pred - meas)^2 / sum meas^2)
};

struct HeldOutView {
  int view = 0;
  std::string name;
  std::vector<float> prediction;  // texel * channels + c (the texel grid)
  std::vector<uint8_t> measured_valid;
  size_t texels = 0;
  double relative_rmse = 0;  // sqrt(sum (pred - meas)^2 / sum meas^2) over the measured texels
};

struct MapsResult {
  TexelData data;  // the samples (without the held-out view's)
  TexelFit fit;    // the selected maps
  std::vector<MapsCandidate> candidates;
  std::string selection_reason;
  ClusterResult clusters;
  std::vector<float> height;  // metres, per texel
  std::string input;          // the session or rectified folder
  std::string lamp_source;
  // The uniform fit that placed the lamp (a session without --lamp): its model and result.
  std::optional<JointFitResult> uniform_fit;
  // The calibration's part of the uncertainty, from refits of the uniform fit (none: no
  // accuracy in photometric.json, --lamp given, or off), and what of it entered the maps.
  std::optional<CalibrationPropagation> calibration_error;
  std::string calibration_error_use;
  std::vector<ViewFit> views;
  std::optional<HeldOutView> held_out;
  std::vector<ViewRegistration> registration;  // per view (all views)
  std::vector<std::string> assumptions, warnings;
  double sample_s = 0, uniform_fit_s = 0, solve_s = 0;

  std::string Report() const;
  nlohmann::json ToJson() const;  // maps.json (docs/formats.md)
};

// The texel data sampled again with each view's registration (a session's frames); empty: the
// search runs on every texel.
using Resampler = std::function<TexelData(const std::vector<ViewRegistration>& registration)>;

// The maps of `data` from the lamp's start: the fits, the choice, the height, the per-view
// residuals and (options.hold_out) the held-out view's prediction.
MapsResult SolveMaps(TexelData data, const MapsLamp& lamp, const MapsOptions& options,
                     const Resampler& resample = {});

// Where view v really shows texel centre p: p + the registration's displacement there.
Eigen::Vector2d DisplacementAt(const ViewRegistration& registration, const TexelGrid& grid,
                               const Eigen::Vector3d& p);

struct MapsSessionInputs {
  Session session;
  Board board;
  CameraModel camera;
  PhotometricCalibration photometric;
  std::vector<std::string> assumptions;
};

// camera_path is required; photometric_path empty: SESSION/photometric.json, else (with
// assume_linear) a linear camera at the session's bit depth, recorded as an assumption, else
// InputError saying how to make one.
MapsSessionInputs LoadMapsSessionInputs(const std::filesystem::path& session_dir,
                                        const std::string& camera_path,
                                        const std::string& photometric_path, bool assume_linear);

// poses: the board poses already located (gonio run), else located here; uniform: the
// joint fit's result to take the lamp from (gonio run), else fitted here unless options.lamp;
// calibration: the calibration error propagated through that fit (gonio run), else
// propagated here through the uniform fit (options.calibration_error); observations: that
// fit's observations (gonio run), whose white reference places the maps' starting lamp
// (estimation/joint/white_lamp.h), else the uniform fit's lamp starts them.
MapsResult MapsFromSession(const MapsSessionInputs& inputs, const MapsOptions& options,
                           const SessionPoses* poses = nullptr,
                           const JointFitResult* uniform = nullptr,
                           const CalibrationPropagation* calibration = nullptr,
                           const ObservationSet* observations = nullptr);

// Adds the calibration part (the uniform fit's refits) in quadrature to the maps' standard
// deviations: the roughness's (shared, per cluster and per texel) when the uniform model has
// the maps' roughness parameter, every texel's albedo by its relative part (one-weight models),
// and the lamp's. Sets result->calibration_error_use to what was added.
void AddMapsCalibrationUncertainty(const CalibrationPropagation& calibration,
                                   const JointFitResult& uniform, MapsResult* result);

// MaterialGAN's rectified layout (docs/maps.md "Rectified captures").
MapsResult MapsFromRectified(const std::filesystem::path& dir, const MapsOptions& options);

// InputError before any work when `out` cannot hold the maps: an input (or inside one), an
// existing file, or a non-empty folder without a previous maps.json.
void CheckMapsOutput(const std::filesystem::path& out,
                     const std::vector<std::filesystem::path>& inputs);

// Writes every output into a temporary sibling of `out` and renames it into place.
void WriteMapsOutputs(const MapsResult& result, const std::filesystem::path& out);

}  // namespace gonio
