// `gonio maps` on a session (maps.h): its inputs, frames, board poses and the uniform fit that
// places the lamp, then the texel samples and SolveMaps.
#include <algorithm>
#include <chrono>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "calib/geometry/detect.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/log.h"
#include "common/session_frames.h"
#include "common/stopwatch.h"
#include "estimation/extract/extract.h"
#include "estimation/joint/white_lamp.h"
#include "estimation/maps/maps.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

// The value of parameter `name` (values in the order of `names`); none when absent.
std::optional<double> Named(const std::vector<std::string>& names,
                            const std::vector<double>& values, const std::string& name) {
  const auto at = std::find(names.begin(), names.end(), name);
  if (at == names.end() || static_cast<size_t>(at - names.begin()) >= values.size()) {
    return std::nullopt;
  }
  return values[at - names.begin()];
}

}  // namespace

MapsSessionInputs LoadMapsSessionInputs(const fs::path& session_dir, const std::string& camera_path,
                                        const std::string& photometric_path, bool assume_linear) {
  MapsSessionInputs in;
  in.session = ReadSession(session_dir);
  if (in.session.board.empty()) {
    throw InputError(session_dir.string() + "/session.json: names no board file");
  }
  in.board = Board::Read(in.session.BoardPath());
  if (camera_path.empty()) throw InputError("--camera: give the camera model (.cameramodel)");
  in.camera = CameraModel::Read(camera_path);
  const fs::path default_photometric = in.session.dir / "photometric.json";
  if (!photometric_path.empty() || (!assume_linear && fs::exists(default_photometric))) {
    const fs::path p = photometric_path.empty() ? default_photometric : fs::path(photometric_path);
    in.photometric = PhotometricCalibration::Read(p);
    if (in.session.bit_depth > 0 && in.photometric.response.bit_depth != in.session.bit_depth) {
      throw InputError(fmt::format("{}: calibrated for {} bits, {} says {} bits", p.string(),
                                   in.photometric.response.bit_depth,
                                   (in.session.dir / "session.json").string(),
                                   in.session.bit_depth));
    }
  } else if (assume_linear) {
    std::string assumption;
    in.photometric = PhotometricCalibration::AssumedLinearFor(in.session, &assumption);
    in.assumptions.push_back(assumption);
  } else {
    throw InputError(
        "no photometric calibration: give --photometric photometric.json (gonio photometric "
        "response / vignette), put one in the session, or --assume-linear");
  }
  return in;
}

namespace {

// Every frame of the session, decoded once through the one frame loop (common/session_frames.h),
// checked against the session and the calibrations as extraction checks them.
std::vector<cv::Mat> ReadFrames(const MapsSessionInputs& in) {
  const Session& session = in.session;
  const ImageExpectation expect = FrameExpectation(
      session, in.photometric, "the photometric calibration", &in.camera, "the camera");
  std::vector<cv::Mat> frames(session.frames.size());
  SessionFrames(session, expect)
      .ForEach("maps: reading frames", [&](size_t i, const cv::Mat& image) { frames[i] = image; });
  return frames;
}

// The board pose of every frame, when the caller (gonio run) has none.
SessionPoses LocateFrames(const MapsSessionInputs& in, const std::vector<cv::Mat>& frames) {
  std::vector<BoardObservation> detections;
  // On radiance, as gonio run finds them (calib/geometry/detect.h GreyForDetection).
  const RadianceTable radiance = in.photometric.response.RadianceByValue();
  for (size_t i = 0; i < frames.size(); ++i) {
    detections.push_back(DetectBoard(GreyForDetection(frames[i], in.session.bit_depth, radiance),
                                     in.board, PoseOptions().detector, in.session.frames[i].file));
  }
  return LocateObservations(in.camera, in.board, detections, PoseOptions(),
                            SessionPoses::TagGrey::kRadiance);
}

// The options of the maps' uniform fit and of the white reference's lamp.
JointFitOptions UniformFitOptions(const MapsOptions& o) {
  JointFitOptions jo;
  jo.lamp_frame = o.lamp_frame;
  jo.white_albedo = o.white_albedo;
  jo.threads = o.threads;
  return jo;
}

// The lamp placed by the white reference alone (estimation/joint/white_lamp.h), logged.
std::optional<JointFitResult> WhiteLamp(const ObservationSet& obs, const MapsOptions& o) {
  std::optional<JointFitResult> white = FitWhiteReferenceLamp(obs, UniformFitOptions(o));
  if (white) {
    const Eigen::Vector3d& p = white->lamp_position;
    spdlog::info("maps: the white reference places the lamp at ({:.4f}, {:.4f}, {:.4f}) m", p.x(),
                 p.y(), p.z());
  } else {
    spdlog::info("maps: no white reference to place the lamp: the uniform fit places it");
  }
  return white;
}

// The lamp from a uniform fit of the same frames (estimation/joint/joint_fit.h), 4x4 patches,
// started from the white reference's lamp (*white) when the board has one. With
// photometric.json's accuracy, the calibration's error is propagated through it as gonio
// run does (pipeline/run.cc), into *calibration; the response's warning where the sample's
// values are (PhotometricCalibration::PriorHeldWarning) into *warnings.
JointFitResult UniformFit(const MapsSessionInputs& in, const MapsOptions& o,
                          const std::vector<cv::Mat>& frames,
                          const std::vector<TexelSampler::Pose>& sampler_poses,
                          const std::vector<size_t>& frame_of,
                          std::optional<CalibrationPropagation>* calibration,
                          std::optional<JointFitResult>* white,
                          std::vector<std::string>* warnings) {
  const Session& session = in.session;
  ExtractOptions eo;
  eo.patch = 4;
  eo.threads = o.threads;
  ObservationExtractor extractor(session.frames, in.camera, in.board, in.photometric, eo);
  for (size_t k = 0; k < sampler_poses.size(); ++k) {
    extractor.AddFrame(frame_of[k], frames[frame_of[k]], sampler_poses[k].cam_from_board,
                       session.FramePath(frame_of[k]).string());
  }
  ObservationSet obs = extractor.Finish(session.dir.string());
  if (auto w =
          PhotometricCalibration::PriorHeldWarning(in.photometric.response, RawValuesOf(obs))) {
    spdlog::warn("{}", *w);
    warnings->push_back(std::move(*w));
  }
  const JointFitOptions jo = UniformFitOptions(o);
  *white = WhiteLamp(obs, o);
  // A deterministic subsample, as the joint fit's final fit takes (30000 observations).
  const size_t stride = std::max<size_t>(1, obs.observations.size() / 30000);
  std::vector<Observation> kept;
  for (size_t i = 0; i < obs.observations.size(); i += stride) kept.push_back(obs.observations[i]);
  obs.observations = std::move(kept);
  const MapsModel maps_model = o.ResolvedModel(o.white_albedo.has_value());
  const std::string model =
      maps_model == MapsModel::kDiffuseGgx ? "oren-nayar" : ToString(maps_model);
  spdlog::info("maps: the lamp from a uniform {} fit of {} observations", model,
               obs.observations.size());
  JointFitResult fit =
      FitJoint(model, obs, *white ? (*white)->lamp_position : InitialLamp(obs, jo), jo);
  if (o.calibration_error.draws == 0 || !fit.material.converged) return fit;
  const std::optional<CalibrationErrorModel> e =
      CalibrationErrorModelAt(in.photometric, obs, in.camera);
  if (e) {
    spdlog::info("maps: propagating the calibration's error ({} refits of the uniform fit)",
                 o.calibration_error.draws);
    *calibration = PropagateCalibrationError(obs, fit, jo, *e, o.calibration_error);
  }
  return fit;
}

// The located frames as the texel sampler takes them (pose, exposure, gain), and in *frame_of
// each one's index in the session's frames.
std::vector<TexelSampler::Pose> SamplerPoses(const Session& session, const SessionPoses& poses,
                                             std::vector<size_t>* frame_of) {
  std::vector<TexelSampler::Pose> sampler_poses;
  for (const auto& f : poses.frames) {
    for (size_t i = 0; i < session.frames.size(); ++i) {
      if (session.frames[i].file != f.file) continue;
      sampler_poses.push_back(
          {f.file, f.pose.cam_from_board, session.frames[i].exposure_s, session.frames[i].gain});
      frame_of->push_back(i);
    }
  }
  return sampler_poses;
}

// The maps' lamp against the white reference's (white_lamp.h): the paper places it whatever the
// sample is, so a lamp the maps moved beyond kShiftInSd of the two bars combined is one their
// model does not hold (textured-3mat without --white-albedo: oren-nayar-qualitative, one
// roughness for three materials, the lamp 14 cm off the paper's with chi2 per residual 1.03).
std::optional<std::string> LampAgainstWhite(const JointFitResult& white, const MapsLamp& lamp) {
  if (!white.lamp_stddev || !lamp.position_sd) return std::nullopt;
  const Eigen::Vector3d shift = lamp.position - white.lamp_position;
  const Eigen::Vector3d sd =
      (white.lamp_stddev->cwiseAbs2() + lamp.position_sd->cwiseAbs2()).cwiseSqrt();
  const double in_sd = UnresolvedNuisance::ShiftInSd(shift, sd);
  if (!(in_sd > UnresolvedNuisance::kShiftInSd)) return std::nullopt;
  return fmt::format(
      "lamp: the maps place it {:.1f} mm from where the white reference places it ({:.1f} "
      "standard deviations): the maps' model does not hold the sample, and their lamp, "
      "roughness and albedo follow that misfit; give --white-albedo (an absolute model), or "
      "--lamp {:.4f},{:.4f},{:.4f} (the white reference's lamp, held)",
      1e3 * shift.norm(), in_sd, white.lamp_position.x(), white.lamp_position.y(),
      white.lamp_position.z());
}

// The maps' starting lamp (MapsFromSession) and what placed it.
struct LampPlacement {
  MapsLamp lamp;
  std::optional<JointFitResult> uniform;  // the uniform fit (none with --lamp)
  std::optional<CalibrationPropagation> calibration;
  std::optional<JointFitResult> white;  // the white reference's lamp (white_lamp.h)
  std::vector<std::string> warnings;
};

// --lamp held; else the white reference's lamp when the board has one, the uniform fit's
// otherwise, with the uniform fit (gonio run's, or fitted here) for the intensity.
LampPlacement PlaceLamp(const MapsSessionInputs& in, const MapsOptions& o,
                        const std::vector<cv::Mat>& frames,
                        const std::vector<TexelSampler::Pose>& sampler_poses,
                        const std::vector<size_t>& frame_of, const JointFitResult* uniform_in,
                        const CalibrationPropagation* calibration_in,
                        const ObservationSet* observations_in) {
  LampPlacement p;
  MapsLamp& lamp = p.lamp;
  lamp.frame =
      o.lamp_frame == LampFrame::kCamera ? MapsLamp::Frame::kCamera : MapsLamp::Frame::kBoard;
  lamp.white_albedo = o.white_albedo;
  if (o.lamp) {
    lamp.position = *o.lamp;
  } else if (uniform_in) {
    p.uniform = *uniform_in;
    if (calibration_in) p.calibration = *calibration_in;
    if (observations_in) p.white = WhiteLamp(*observations_in, o);
  } else {
    p.uniform =
        UniformFit(in, o, frames, sampler_poses, frame_of, &p.calibration, &p.white, &p.warnings);
  }
  if (p.uniform) {
    // A textured sample's uniform fit places the lamp only as well as one material holds it;
    // the white reference's lamp does not depend on the sample (white_lamp.h).
    lamp.position = p.white ? p.white->lamp_position : p.uniform->lamp_position;
    lamp.intensity = p.uniform->intensity;
    lamp.refine_position = lamp.position_fitted = true;
    lamp.from_reference = p.white.has_value();
  }
  return p;
}

}  // namespace

MapsResult MapsFromSession(const MapsSessionInputs& in, const MapsOptions& o,
                           const SessionPoses* poses_in, const JointFitResult* uniform_in,
                           const CalibrationPropagation* calibration_in,
                           const ObservationSet* observations_in) {
  o.Check();
  const auto t0 = std::chrono::steady_clock::now();
  const Session& session = in.session;
  const std::vector<cv::Mat> frames = ReadFrames(in);
  SessionPoses located;
  if (!poses_in) located = LocateFrames(in, frames);
  const SessionPoses& poses = poses_in ? *poses_in : located;
  if (poses.frames.empty()) throw InputError(session.dir.string() + ": the board is in no frame");
  std::vector<size_t> frame_of;
  const std::vector<TexelSampler::Pose> sampler_poses = SamplerPoses(session, poses, &frame_of);
  const double read_s = SecondsSince(t0);
  const auto t_fit = std::chrono::steady_clock::now();
  LampPlacement placed = PlaceLamp(in, o, frames, sampler_poses, frame_of, uniform_in,
                                   calibration_in, observations_in);
  const MapsLamp& lamp = placed.lamp;
  const std::optional<JointFitResult>& uniform = placed.uniform;
  const std::optional<JointFitResult>& white = placed.white;
  std::vector<std::string>& warnings = placed.warnings;
  const double fit_s = SecondsSince(t_fit);
  const auto t_sample = std::chrono::steady_clock::now();
  // The frames stay decoded until the maps are fitted: a large grid samples them again with
  // each view's registration (SolveMaps).
  auto sample = [&](const std::vector<ViewRegistration>* registration) {
    TexelSampler sampler(in.camera, in.board, in.photometric, sampler_poses, o.sampling);
    for (size_t k = 0; k < sampler_poses.size(); ++k) {
      const std::function<Eigen::Vector2d(const Eigen::Vector3d&)> displacement =
          [&, k](const Eigen::Vector3d& p) {
            return DisplacementAt((*registration)[k], sampler.grid(), p);
          };
      sampler.AddFrame(k, frames[frame_of[k]], session.FramePath(frame_of[k]).string(),
                       registration ? &displacement : nullptr);
    }
    return sampler.Finish(session.dir.string());
  };
  TexelData data = sample(nullptr);
  spdlog::info("maps: {} x {} texels of {:.3f} mm, {} views", data.grid.width, data.grid.height,
               1e3 * data.grid.texel, data.views.size());
  const double sample_s = read_s + SecondsSince(t_sample);
  MapsResult r = SolveMaps(std::move(data), lamp, o,
                           [&](const std::vector<ViewRegistration>& g) { return sample(&g); });
  r.sample_s = sample_s;
  r.uniform_fit_s = fit_s;
  r.uniform_fit = uniform;
  if (placed.calibration && uniform) {
    AddMapsCalibrationUncertainty(*placed.calibration, *uniform, &r);
  }
  if (white) {
    if (auto w = LampAgainstWhite(*white, r.fit.lamp)) {
      spdlog::warn("maps: {}", *w);
      warnings.push_back(std::move(*w));
    }
  }
  r.input = session.dir.string();
  r.lamp_source = o.lamp  ? "--lamp (held fixed)"
                  : white ? "the white reference (lambert), refined with the maps"
                          : fmt::format("uniform {} fit{}, refined with the maps",
                                        uniform ? uniform->material.model : "",
                                        uniform_in ? " of gonio run" : "");
  for (const auto& a : in.assumptions) r.assumptions.insert(r.assumptions.begin(), a);
  for (const auto& s : poses.skipped) {
    r.warnings.push_back(fmt::format("frame {} skipped: {}", s.file, s.reason));
  }
  r.warnings.insert(r.warnings.begin(), warnings.begin(), warnings.end());
  return r;
}

void AddMapsCalibrationUncertainty(const CalibrationPropagation& calibration,
                                   const JointFitResult& uniform, MapsResult* r) {
  TexelFit& f = r->fit;
  const MapsModelInfo info = InfoOf(f.model);
  auto part = [&](const std::string& name) {
    return Named(calibration.param_names, calibration.param_stddev, name);
  };
  std::vector<std::string> added;
  // A calibration error bends every view the same way, so it moves the shared roughness as it
  // moves the uniform fit's: the same model's parameter in the same unit, else not added.
  if (const auto sd = info.has_roughness ? part(info.roughness_name) : std::nullopt) {
    for (auto& c : f.cluster_r_sd) c = std::hypot(c, *sd);
    for (size_t t = 0; t < f.sd_r.size(); ++t) {
      if (f.fitted[t]) f.sd_r[t] = static_cast<float>(std::hypot(f.sd_r[t], *sd));
    }
    added.push_back(fmt::format("{} +-{:.3g} {}", info.roughness_name, *sd, info.roughness_unit));
  }
  // The albedo's part is a common scale: its relative size times every texel's albedo.
  const std::optional<double> albedo_sd = part("albedo");
  const std::optional<double> albedo =
      Named(uniform.material.param_names, uniform.material.params, "albedo");
  if (albedo_sd && albedo && f.m == 1 && *albedo > 0) {
    const double rel = *albedo_sd / *albedo;
    for (size_t k = 0; k < f.sd_w.size(); ++k) {
      f.sd_w[k] = static_cast<float>(std::hypot(f.sd_w[k], rel * f.w[k]));
    }
    added.push_back(fmt::format("albedo +-{:.2f}%", 100 * rel));
  }
  if (f.lamp.position_sd) {
    for (int k = 0; k < 3; ++k) {
      (*f.lamp.position_sd)[k] = std::hypot((*f.lamp.position_sd)[k], calibration.lamp_stddev[k]);
    }
    added.push_back(fmt::format("lamp +-{:.2g} m", calibration.lamp_stddev.maxCoeff()));
  }
  r->calibration_error = calibration;
  r->calibration_error_use = added.empty() ? "none of it (the maps' model has other parameters)"
                                           : fmt::format("{}", fmt::join(added, ", "));
}

}  // namespace gonio
