#include "pipeline/photometric_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/plot.h"
#include "common/session_frames.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

void PlotResponse(const ResponseResult& r, const std::string& png) {
  PlotSpec spec;
  spec.title = fmt::format("inverse response ({} bit), pair consistency {:.2f}% (median pair)",
                           r.bit_depth, 100 * r.consistency.median_pair);
  spec.xlabel = "pixel value";
  spec.ylabel = "relative exposure (log)";
  spec.log_y = true;
  const char* names[] = {"B", "G", "R"};
  for (int c = 0; c < r.channels; ++c) {
    PlotSeries s;
    s.label = r.channels == 3 ? names[c] : "grey";
    for (size_t z = 0; z < r.inverse_response[c].size(); ++z) {
      if (r.inverse_response[c][z] <= 0) continue;
      s.x.push_back(z);
      s.y.push_back(r.inverse_response[c][z]);
    }
    spec.series.push_back(std::move(s));
  }
  RenderPlot(spec, png);
}

// The bit depth: --bit-depth, or the sweep's session.json; both must agree.
int StatedBitDepth(int option, const ExposureSweep& sweep, std::string* stated_by) {
  if (option != 0 && sweep.bit_depth != 0 && option != sweep.bit_depth) {
    throw InputError(fmt::format("--bit-depth {} contradicts bit_depth {} in {}", option,
                                 sweep.bit_depth, sweep.bit_depth_source));
  }
  *stated_by = option != 0 ? "--bit-depth" : sweep.bit_depth_source;
  return option != 0 ? option : sweep.bit_depth;
}

// A lamp that moves with the camera lights the board differently in every pose: the method's
// view-independent board texture does not exist and V would hold the lamp's fall-off.
constexpr const char* kVignetteAlternatives =
    "calibrate vignetting from a flat field (gonio synth --preset flat-field renders one) or a "
    "separate session with the lamp fixed to the board";

// The frames of the session, each with its pose from o.poses (frames gonio locate skipped are
// left out), or without poses for a flat field.
std::vector<VignetteFrame> VignetteFrames(const SessionVignetteOptions& o, const Session& session,
                                          const PhotometricCalibration& calib) {
  std::vector<std::pair<std::string, Rigid3d>> poses;
  if (!o.poses.empty()) poses = ReadPoses(o.poses);
  std::vector<VignetteFrame> frames;
  const auto pose_of = [&](size_t i) {
    return std::find_if(poses.begin(), poses.end(),
                        [&](const auto& p) { return p.first == session.frames[i].file; });
  };
  SessionFrames(session, CalibratedFrameExpectation(calib, o.response))
      .ForEach(
          "read",
          [&](size_t i, const cv::Mat& image) {
            VignetteFrame f;
            if (!o.poses.empty()) f.cam_from_board = pose_of(i)->second;
            f.file = session.frames[i].file;
            f.image = image;
            f.exposure_s = session.frames[i].exposure_s;
            f.gain = session.frames[i].gain;
            frames.push_back(std::move(f));
          },
          // Without a pose (gonio locate skipped it) a board frame is left out.
          [&](size_t i) { return o.poses.empty() || pose_of(i) != poses.end(); });
  if (frames.empty()) {
    throw InputError(o.poses.empty() ? o.session + ": holds no frame"
                                     : o.poses + ": no pose for any frame of " + o.session);
  }
  return frames;
}

// A flat field (no poses): no board, or a board file without tags. A board with tags needs
// the poses that tell which board point each pixel sees.
bool IsFlatField(const SessionVignetteOptions& o, std::optional<PaperRegion>* board) {
  if (!o.board.empty()) *board = PaperRegion::Read(o.board);
  if (!o.poses.empty()) {
    if (!*board) throw InputError("--poses: needs --board, the board the poses refer to");
    return false;
  }
  if (*board && !(*board)->uniform) {
    throw InputError("--poses: " + o.board +
                     " has tags, so each pixel's board point must come from the poses (gonio "
                     "locate writes them); only a flat field (a tag-free target) needs none");
  }
  return true;
}

nlohmann::json VignetteJson(const SessionVignette& v, const std::string& out) {
  const VignetteResult& r = v.result;
  const CameraModel& camera = v.camera;
  return {{"format", "gonio-vignette"},
          {"version", 1},
          {"map", fs::path(out).filename().string()},
          {"model", ToString(r.model_used)},
          {"radial",
           {{"coefficients", r.radial},
            {"center", {camera.intrinsics[2], camera.intrinsics[3]}},
            {"radius_px", 0.5 * std::hypot(camera.width, camera.height)}}},
          {"coverage", r.coverage},
          {"frames_used", r.frames_used},
          {"poses", r.poses},
          {"samples", r.samples},
          {"rms_relative_residual", r.rms_relative_residual},
          {"map_error_rms",
           std::isfinite(r.map_error_rms) ? nlohmann::json(r.map_error_rms) : nlohmann::json()},
          {"map_error_note", r.map_error_note},
          {"map_vs_radial_rms", r.map_vs_radial_rms},
          {"cell_correction_rms",
           r.cell_correction_rms ? nlohmann::json(*r.cell_correction_rms) : nlohmann::json()},
          {"flat_field", v.flat_field},
          {"lamp_test",
           {{"run", r.lamp_test.run},
            {"camera_lamp_exponent", r.lamp_test.exponent},
            {"camera_lamp_exponent_stddev", r.lamp_test.exponent_stddev},
            {"unexplained_rms", r.lamp_test.unexplained_rms},
            {"detectable", r.lamp_test.detectable},
            {"partly_camera_fixed", r.lamp_test.partly_camera_fixed}}},
          {"note", r.note}};
}

}  // namespace

void SweepResponseOptions::Check() const {
  if (sweep.empty()) throw InputError("--sweep: give the sweep's folder");
  if (bit_depth != 0 && (bit_depth < 8 || bit_depth > 16)) {
    throw InputError("--bit-depth: must be 8 to 16 (or left out: the sweep's)");
  }
  if (black_level && !(*black_level >= 0 && std::isfinite(*black_level))) {
    throw InputError("--black-level: must be a finite value >= 0");
  }
  if (!(exposure_tolerance > 0 && exposure_tolerance < 1)) {
    throw InputError("--exposure-tolerance: must be in (0, 1)");
  }
  response.Check();
}

SweepResponse CalibrateSweepResponse(const SweepResponseOptions& o) {
  o.Check();
  SweepResponse out;
  ExposureSweep& sweep = out.sweep;
  sweep = LoadSweepFolder(o.sweep, o.list);
  if (!o.dark.empty()) {
    if (!sweep.dark_frames.empty()) {
      throw InputError("--dark: " + sweep.session_file +
                       " already lists dark_frames; give them in one place");
    }
    AddDarkFrames(o.sweep, o.dark, &sweep);
  }
  if (o.exclude) MaskColour(*o.exclude, &sweep.frames);
  std::string stated_by;
  ResponseOptions ro = o.response;
  ro.bit_depth = StatedBitDepth(o.bit_depth, sweep, &stated_by);
  // Checked here too so that a mismatch names the file that stated the depth.
  std::vector<ExposureFrame> checked = sweep.frames;
  ro.bit_depth = ResolveBitDepth(ro.bit_depth, stated_by, &checked);
  ResolveBlackLevel(sweep, o.black_level, checked, ro.bit_depth, &ro);
  ro.drop_inconsistent = o.drop_inconsistent;
  ro.exposure_tolerance = o.exposure_tolerance;
  if (o.compare_opencv && ro.bit_depth != 8) {
    throw InputError(fmt::format(
        "--compare-opencv: OpenCV's Debevec and Robertson read 8-bit frames; {} is {} bit", o.sweep,
        ro.bit_depth));
  }
  spdlog::info("calibrating the inverse response from {} frames ({} bit)", sweep.frames.size(),
               ro.bit_depth);
  const auto t0 = std::chrono::steady_clock::now();
  out.result = CalibrateResponse(sweep.frames, ro);
  out.calibrate_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  spdlog::info("inverse response calibrated in {:.2f} s", out.calibrate_s);
  if (out.result.BlackLevelUncertain()) {
    spdlog::warn(
        "the black level is estimated from the curve's shape and the data allow a wide range "
        "(see below): shoot dark frames with the lens capped and list them in session.json "
        "dark_frames, or give --black-level (docs/capture.md)");
  }
  return out;
}

nlohmann::json CompareWithOpenCv(const SweepResponse& r, std::ostream& out) {
  nlohmann::json j = nlohmann::json::array();
  out << "pair consistency on the frames and times gonio used, values 5-95% of the range:\n";
  for (const auto& m : CompareWithClassicMethods(r.sweep.frames, r.result, r.calibrate_s)) {
    out << fmt::format(
        "  {:<17} median pair {:6.2f}%  worst pair {:6.2f}%  worst band bias "
        "{:6.2f}%  calibrated in {:6.2f} s\n",
        m.method, 100 * m.consistency.median_pair, 100 * m.consistency.worst_pair,
        100 * m.consistency.worst_band_bias, m.calibrate_s);
    j.push_back({{"method", m.method},
                 {"consistency", m.consistency.ToJson()},
                 {"calibrate_s", m.calibrate_s}});
  }
  return j;
}

void WriteSweepResponse(const SweepResponse& r, const SweepResponseOptions& o,
                        const nlohmann::json& comparison, const std::string& out,
                        const std::string& plot) {
  nlohmann::json j = r.result.ToJson();
  j["sweep"] = o.sweep;
  if (!o.list.empty()) j["list"] = o.list;
  j["calibrate_s"] = r.calibrate_s;
  if (!comparison.is_null()) j["comparison"] = comparison;
  const std::string png = plot.empty() ? (fs::path(out).replace_extension(".png")).string() : plot;
  PlotResponse(r.result, png);
  j["plot"] = png;
  WriteJsonAtomically(out, j);
}

cv::Mat ReadCalibratedFrame(const fs::path& file, const PhotometricCalibration& calib,
                            const std::string& calib_what) {
  return ReadImage(file, CalibratedFrameExpectation(calib, calib_what));
}

ImageExpectation CalibratedFrameExpectation(const PhotometricCalibration& calib,
                                            const std::string& calib_what) {
  ImageExpectation expect;
  expect.bit_depth = calib.response.bit_depth;
  expect.bit_depth_of = "the photometric calibration " + calib_what;
  expect.channels = calib.response.channels;
  expect.channels_of = "the photometric calibration " + calib_what;
  expect.size = calib.vignette.size();
  expect.size_of = "the vignetting map " + calib.vignette_file.string();
  return expect;
}

PhotometricCalibration RawFramesCalibration(int channels, double white_level, double black_level) {
  PhotometricCalibration p =
      PhotometricCalibration::Linear(16, channels, 0.0, BlackLevelSource::kRawMetadata);
  p.read_noise_dn = 65535.0 / (white_level - black_level) * std::sqrt(1.0 + 1.0 / 12.0);
  return p;
}

void SessionVignetteOptions::Check() const {
  if (session.empty()) throw InputError("--session: give the session folder");
  if (camera.empty()) throw InputError("--camera: give the camera model");
  if (response.empty()) throw InputError("--response: give the response.json");
  vignette.Check();
}

SessionVignette CalibrateSessionVignette(const SessionVignetteOptions& o) {
  o.Check();
  SessionVignette v;
  std::optional<PaperRegion> board;
  v.flat_field = IsFlatField(o, &board);
  if (o.lamp_frame == LampFrame::kCamera) {
    throw InputError(
        v.flat_field
            ? std::string("--lamp-frame camera: a lamp on the camera does not light a flat "
                          "field evenly; light the target evenly (a light panel, a "
                          "diffuser) and leave --lamp-frame out")
            : std::string("--lamp-frame camera: a lamp that moves with the camera would "
                          "put its fall-off into the vignetting; ") +
                  kVignetteAlternatives);
  }
  const Session session = ReadSession(o.session);
  v.camera = CameraModel::Read(o.camera);
  v.calib.response = ResponseResult::FromJson(ReadJsonFile(o.response), o.response);
  const std::vector<VignetteFrame> frames = VignetteFrames(o, session, v.calib);
  spdlog::info("vignetting from {} frames{}", frames.size(),
               v.flat_field ? " of a flat field (no poses)" : "");
  try {
    v.result = v.flat_field ? CalibrateFlatFieldVignette(v.camera, v.calib, frames, o.vignette)
                            : CalibrateVignette(v.camera, *board, v.calib, frames, o.vignette);
  } catch (const InputError& e) {
    throw InputError(o.session + ": " + e.what());  // which session the frames came from
  }
  return v;
}

void WriteSessionVignette(const SessionVignette& v, const std::string& out,
                          const std::string& photometric_out) {
  if (fs::path(out).has_parent_path()) EnsureDirectory(fs::path(out).parent_path());
  WriteImage(out, v.result.map);
  // Visualisation: V in [0.5, 1] stretched to 8 bits.
  cv::Mat vis;
  v.result.map.convertTo(vis, CV_8U, 255.0 / 0.5, -255.0);
  cv::applyColorMap(vis, vis, cv::COLORMAP_VIRIDIS);
  WriteImage(fs::path(out).replace_extension(".png"), vis);
  WriteJsonAtomically(fs::path(out).replace_extension(".json"), VignetteJson(v, out));
  if (!photometric_out.empty()) {
    const fs::path path(photometric_out);
    if (path.has_parent_path()) EnsureDirectory(path.parent_path());
    WithVignette(v.calib, v.result).Write(photometric_out);
  }
}

ApplyCount ApplyPhotometric(const std::string& image, const std::string& photometric,
                            double exposure_s, double gain, const std::string& out,
                            const std::string& variance) {
  const PhotometricCalibration calib = PhotometricCalibration::Read(photometric);
  const cv::Mat raw = ReadCalibratedFrame(image, calib, photometric);
  cv::Mat radiance, var, valid;
  calib.ToRadiance(raw, exposure_s, gain, &radiance, &var, &valid);
  for (const fs::path& path : {fs::path(out), fs::path(variance)}) {
    if (path.has_parent_path()) EnsureDirectory(path.parent_path());
  }
  WriteImage(out, radiance);
  if (!variance.empty()) WriteImage(variance, var);
  return {cv::countNonZero(valid), valid.total()};
}

void MergeSessionBrackets(const std::string& session_dir, const std::string& photometric,
                          const std::string& out,
                          const std::function<void(const HdrBracket&)>& on_bracket) {
  const Session session = ReadSession(session_dir);
  const PhotometricCalibration calib = PhotometricCalibration::Read(photometric);
  SessionFrames session_frames(session, CalibratedFrameExpectation(calib, photometric));
  std::map<int, std::vector<size_t>> brackets;
  for (size_t i = 0; i < session.frames.size(); ++i) {
    brackets[session.frames[i].bracket].push_back(i);
  }
  EnsureDirectory(out);
  nlohmann::json index = {{"format", "gonio-hdr"},
                          {"version", 1},
                          {"session", session_dir},
                          {"photometric", photometric}};
  index["poses"] = nlohmann::json::array();
  for (const auto& [bracket, members] : brackets) {
    std::vector<HdrFrame> frames;
    nlohmann::json sources = nlohmann::json::array();
    for (size_t i : members) {
      HdrFrame f;
      f.file = session.frames[i].file;
      f.raw = session_frames.Read(i);
      f.exposure_s = session.frames[i].exposure_s;
      f.gain = session.frames[i].gain;
      sources.push_back(f.file);
      frames.push_back(std::move(f));
    }
    const HdrResult r = MergeBracket(calib, frames);
    const std::string stem = fmt::format("radiance_{:04d}", bracket);
    WriteImage(fs::path(out) / (stem + ".tiff"), r.radiance);
    WriteImage(fs::path(out) / (stem + "_variance.tiff"), r.variance);
    WriteImage(fs::path(out) / (stem + "_valid.png"), r.valid);
    index["poses"].push_back({{"bracket", bracket},
                              {"radiance", stem + ".tiff"},
                              {"variance", stem + "_variance.tiff"},
                              {"valid", stem + "_valid.png"},
                              {"frames", sources},
                              {"valid_fraction", r.valid_fraction},
                              {"extended_fraction", r.extended_fraction}});
    on_bracket({bracket, frames.size(), r});
  }
  WriteJsonAtomically(fs::path(out) / "hdr.json", index);
}

}  // namespace gonio
