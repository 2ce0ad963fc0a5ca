// Reading exposure sweeps and response.json, and what a ResponseResult says of itself
// (calib/photometry/response.h); the calibration itself is response.cc.
#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "calib/photometry/response.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/session_frames.h"

namespace gonio {
namespace {

// One image of a sweep (frame or dark frame) as stored, 8- or 16-bit; 4 channels lose their
// alpha. InputError naming the file when it cannot be read.
ImageExpectation SweepImageExpectation() {
  ImageExpectation expect;
  expect.alpha = ImageExpectation::Alpha::kDrop;
  return expect;
}

cv::Mat ReadSweepImage(const std::string& path) { return ReadImage(path, SweepImageExpectation()); }

}  // namespace

std::vector<ExposureFrame> LoadExposureSweep(const std::string& dir, const std::string& list_file) {
  std::ifstream in(list_file);
  if (!in) throw InputError(list_file + ": cannot be read");
  std::vector<ExposureFrame> frames;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line = line.substr(0, hash);
    std::istringstream ss(line);
    ExposureFrame f;
    if (!(ss >> f.file)) continue;
    if (!(ss >> f.exposure_s) || !(f.exposure_s > 0) || !std::isfinite(f.exposure_s)) {
      throw InputError(
          fmt::format("{}: line {}: expected 'file exposure_seconds'", list_file, line_no));
    }
    const std::string path = dir + "/" + f.file;
    f.image = ReadSweepImage(path);
    if (!frames.empty() &&
        (f.image.size() != frames[0].image.size() || f.image.type() != frames[0].image.type())) {
      throw InputError(path + ": size or type differs from " + frames[0].file);
    }
    frames.push_back(std::move(f));
  }
  if (frames.size() < 2) {
    throw InputError(list_file + ": an exposure sweep needs at least two frames");
  }
  return frames;
}

void AddDarkFrames(const std::string& dir, const std::vector<std::string>& files,
                   ExposureSweep* sweep) {
  for (const auto& file : files) {
    const std::filesystem::path path = std::filesystem::path(dir) / file;  // absolute stays
    ExposureFrame f;
    f.file = file;
    f.image = ReadSweepImage(path.string());
    sweep->dark_frames.push_back(std::move(f));
  }
}

ExposureSweep LoadSweepFolder(const std::string& dir, const std::string& list_file) {
  namespace fs = std::filesystem;
  ExposureSweep sweep;
  const fs::path session_file = fs::path(dir) / "session.json";
  if (fs::exists(session_file)) {
    const Session session = ReadSession(session_file);
    sweep.bit_depth = session.bit_depth;
    sweep.bit_depth_source = sweep.session_file = session_file.string();
    if (session.black_level >= 0) sweep.black_level = session.black_level;
    AddDarkFrames(dir, session.dark_frames, &sweep);
    if (list_file.empty()) {
      SessionFrames(session, SweepImageExpectation())
          .ForEach("read", [&](size_t i, const cv::Mat& image) {
            ExposureFrame f;
            f.file = session.frames[i].file;
            f.exposure_s = session.frames[i].exposure_s * session.frames[i].gain;
            f.image = image;
            sweep.frames.push_back(std::move(f));
          });
      if (sweep.frames.size() < 2) {
        throw InputError(session_file.string() + ": an exposure sweep needs at least two frames");
      }
      return sweep;
    }
  }
  sweep.frames = LoadExposureSweep(
      dir, list_file.empty() ? (fs::path(dir) / "image_list.txt").string() : list_file);
  return sweep;
}

void MaskColour(const cv::Scalar& bgr, std::vector<ExposureFrame>* frames) {
  for (auto& f : *frames) {
    if (f.image.channels() != 3) throw InputError(f.file + ": a colour mask needs RGB frames");
    cv::Mat match;
    cv::inRange(f.image, bgr, bgr, match);
    if (f.mask.empty()) f.mask = cv::Mat(f.image.size(), CV_8U, cv::Scalar(255));
    f.mask.setTo(0, match);
  }
}

namespace {

// Number of low bits that are zero in every value of every frame (16 when all are zero).
int CommonTrailingZeroBits(const std::vector<ExposureFrame>& frames) {
  unsigned all = 0;
  for (const auto& f : frames) {
    cv::Mat v = f.image.reshape(1);
    for (int y = 0; y < v.rows; ++y) {
      const uint16_t* row = v.ptr<uint16_t>(y);
      for (int x = 0; x < v.cols; ++x) all |= row[x];
    }
  }
  int zeros = 0;
  while (zeros < 16 && !(all & (1u << zeros))) ++zeros;
  return zeros;
}

double MaxValue(const std::vector<ExposureFrame>& frames, std::string* file) {
  double top = 0;
  for (const auto& f : frames) {
    double m = 0;
    cv::minMaxLoc(f.image.reshape(1), nullptr, &m);
    if (m > top) {
      top = m;
      *file = f.file;
    }
  }
  return top;
}

}  // namespace

int ResolveBitDepth(int stated, const std::string& stated_by, std::vector<ExposureFrame>* frames,
                    ValuePacking* packing) {
  if (packing) *packing = ValuePacking::kNative;
  const bool eight = frames->front().image.depth() == CV_8U;
  if (eight) {
    if (stated != 0 && stated != 8) {
      throw InputError(fmt::format("{}: states {} bits, but {} holds 8-bit values", stated_by,
                                   stated, frames->front().file));
    }
    return 8;
  }
  std::string top_file;
  const double top = MaxValue(*frames, &top_file);
  const int zeros = CommonTrailingZeroBits(*frames);
  if (stated == 0 || stated == 16) {
    // Frames whose values all have their low bits zero are N < 16 bits MSB-aligned.
    if (zeros >= 2 && zeros < 16 && top > 0) {
      throw InputError(fmt::format(
          "{}: every value is a multiple of {}: {}-bit values MSB-aligned in 16 bits; gonio reads "
          "LSB-aligned values, shift the frames right by {} bits and state bit_depth {}",
          frames->front().file, 1 << zeros, 16 - zeros, zeros, 16 - zeros));
    }
    return 16;
  }
  const double max_value = std::ldexp(1.0, stated) - 1;
  if (top <= max_value) {
    if (packing) *packing = ValuePacking::kLsbAligned;
    return stated;
  }
  if (zeros >= 16 - stated) {
    throw InputError(fmt::format(
        "{}: {}-bit values MSB-aligned in 16 bits (every value a multiple of {}); gonio reads "
        "LSB-aligned values: shift the frames right by {} bits",
        top_file, stated, 1 << (16 - stated), 16 - stated));
  }
  throw InputError(fmt::format("{}: value {} does not fit the {} bits {} states", top_file, top,
                               stated, stated_by));
}

double LinearizeTable(const std::vector<double>& t, double value) {
  const double z = std::clamp(value, 0.0, static_cast<double>(t.size() - 1));
  const size_t k = std::min(static_cast<size_t>(z), t.size() - 2);
  const double a = z - k;
  return (1 - a) * t[k] + a * t[k + 1];
}

double ResponseResult::Linearize(int channel, double value) const {
  return LinearizeTable(inverse_response.at(channel), value);
}

double ResponseResult::Slope(int channel, double value) const {
  const auto& t = inverse_response.at(channel);
  const size_t k =
      std::min(static_cast<size_t>(std::clamp(value, 0.0, t.size() - 2.0)), t.size() - 2);
  return t[k + 1] - t[k];
}

std::vector<std::vector<float>> ResponseResult::RadianceByValue() const {
  const size_t values = static_cast<size_t>(1) << bit_depth;
  std::vector<std::vector<float>> out(inverse_response.size(), std::vector<float>(values));
  for (size_t c = 0; c < out.size(); ++c) {
    for (size_t v = 0; v < values; ++v) {
      out[c][v] = static_cast<float>(std::max(0.0, Linearize(static_cast<int>(c), v)));
    }
  }
  return out;
}

bool ResponseResult::BlackLevelUncertain() const {
  const double max_value = std::ldexp(1.0, bit_depth) - 1;
  for (const auto& r : black_level_range) {
    if (r[1] - r[0] > 0.02 * max_value) return true;
  }
  return false;
}

std::string ResponseResult::Report() const {
  std::ostringstream s;
  s << fmt::format("inverse response: {} channel(s), {} bit, black level", channels, bit_depth);
  for (double b : black_level) s << fmt::format(" {:.1f}", b);
  s << fmt::format(" ({}); fit rms {:.4f} (ln units){}\n", BlackLevelSourceName(black_level_source),
                   rms_log_residual,
                   sampled_pixels > 0 ? fmt::format(" on {} pixels per channel", sampled_pixels)
                                      : std::string());
  if (black_level_source == BlackLevelSource::kEstimated) {
    s << "  black level estimated from the curve's shape; the data allow";
    for (const auto& r : black_level_range) s << fmt::format(" {:.1f}..{:.1f}", r[0], r[1]);
    s << (BlackLevelUncertain() ? ": shoot dark frames (docs/capture.md) or state it\n" : "\n");
  }
  s << fmt::format(
      "pair consistency over values {:.0f}..{:.0f}: median pair {:.2f}%, worst pair {:.2f}%; "
      "worst value-band bias {:.2f}%\n",
      consistency.range_lo, consistency.range_hi, 100 * consistency.median_pair,
      100 * consistency.worst_pair, 100 * consistency.worst_band_bias);
  if (std::isfinite(smoothing_sensitivity)) {
    s << fmt::format(
        "smoothing sensitivity {:.2f}% (the curve's change under a 4x stiffer prior, worst value "
        "band: its error between the values the sweep holds){}\n",
        100 * smoothing_sensitivity,
        smoothing_sensitivity > kSmoothingSensitivityLimit
            ? "; narrowed by " + SweepRemedy(ExposurePeriodOctaves(*this))
            : "");
  }
  for (const auto& e : ends) {
    if (e.error < 0.005) continue;
    s << fmt::format(
        "{} end of channel {}: beyond value {:.0f} the curve rests on the prior, not the sweep "
        "(it moves {:.1f}% under a 4x stiffer prior); observations there carry that error, which "
        "a sweep with more of its samples at these values would shrink\n",
        e.taper_to > e.end ? "dark" : "bright", e.channel, e.end, 100 * e.error);
  }
  for (const auto& f : frames) {
    s << fmt::format(
        "  {:<20} listed {:>10.5g} s  used {:>10.5g} s  {}\n", f.file, f.listed_s, f.estimated_s,
        !f.used ? "left out: " + f.note
                : (f.consistent ? (f.note.empty() ? "ok" : "ok (re-timed: " + f.note + ")")
                                : "re-timed: " + f.note));
  }
  return s.str();
}

double ResponseEnd::WeightAt(double z) const {
  const double span = taper_to - end;  // > 0 at a dark end, < 0 at a bright one
  if (!(std::abs(span) > 0)) return (z - end) * span <= 0 ? 1.0 : 0.0;
  return std::clamp(1.0 - (z - end) / span, 0.0, 1.0);
}

namespace {

// Per refit, per channel, one finite ln change per knot (at least two knots, the same count
// throughout); InputError naming `source` otherwise.
std::vector<std::vector<std::vector<double>>> BootstrapFromJson(const nlohmann::json& j,
                                                                int channels,
                                                                const std::string& source) {
  const std::string bad = source +
                          ": 'bootstrap_ln_change' must hold, per refit, one array of finite "
                          "numbers per channel, every one of the same length (at least 2)";
  std::vector<std::vector<std::vector<double>>> out;
  try {
    out = j.get<std::vector<std::vector<std::vector<double>>>>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(bad);
  }
  const size_t knots = out.empty() || out[0].empty() ? 0 : out[0][0].size();
  for (const auto& refit : out) {
    if (static_cast<int>(refit.size()) != channels) throw InputError(bad);
    for (const auto& d : refit) {
      if (d.size() != knots || knots < 2) throw InputError(bad);
      for (double v : d) {
        if (!std::isfinite(v)) throw InputError(bad);
      }
    }
  }
  return out;
}

// response.json smoothing_sensitivity_bands: empty, or PairConsistency::kBands figures >= 0
// (null: NaN, no knot in the band); InputError naming `source` otherwise.
std::vector<double> BandsFromJson(const nlohmann::json& bands, const std::string& source) {
  const std::string what = source + ": 'smoothing_sensitivity_bands' must be empty or a list of " +
                           std::to_string(PairConsistency::kBands) +
                           " non-negative numbers or nulls";
  if (!bands.is_array() || (!bands.empty() && bands.size() != PairConsistency::kBands)) {
    throw InputError(what);
  }
  std::vector<double> out;
  for (const auto& v : bands) {
    if (v.is_null()) {
      out.push_back(NAN);
      continue;
    }
    if (!v.is_number() || !(v.get<double>() >= 0) || !std::isfinite(v.get<double>())) {
      throw InputError(what);
    }
    out.push_back(v.get<double>());
  }
  return out;
}

nlohmann::json NullForNan(const std::vector<double>& values) {
  nlohmann::json out = nlohmann::json::array();
  for (double v : values) out.push_back(std::isfinite(v) ? nlohmann::json(v) : nlohmann::json());
  return out;
}

nlohmann::json EndsToJson(const std::vector<ResponseEnd>& ends) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& e : ends) {
    out.push_back(
        {{"channel", e.channel}, {"end", e.end}, {"taper_to", e.taper_to}, {"error", e.error}});
  }
  return out;
}

// What EndsToJson wrote; InputError naming `source` on a wrong type, a channel out of range or
// an error outside [0, 1).
std::vector<ResponseEnd> EndsFromJson(const nlohmann::json& j, int channels,
                                      const std::string& source) {
  std::vector<ResponseEnd> out;
  if (!j.is_array()) throw InputError(source + ": 'ends' must be an array");
  for (const auto& item : j) {
    ResponseEnd e;
    try {
      e.channel = item.at("channel").get<int>();
      e.end = item.at("end").get<double>();
      e.taper_to = item.at("taper_to").get<double>();
      e.error = item.at("error").get<double>();
    } catch (const nlohmann::json::exception&) {
      throw InputError(source + ": each of 'ends' needs channel, end, taper_to and error");
    }
    if (e.channel < 0 || e.channel >= channels || !std::isfinite(e.end) ||
        !std::isfinite(e.taper_to) || !(e.error >= 0 && e.error < 1)) {
      throw InputError(source + ": 'ends' holds a channel out of range or an error outside [0, 1)");
    }
    out.push_back(e);
  }
  return out;
}

// The sweep's frames as ToJson writes them. Read back because what the sweep's exposure step
// leaves to the smoothing prior repeats with that step (ExposureStepOctaves,
// estimation/joint/calibration_error.h): until 2026-12-04 they were
// dropped here, so every response read from a file had a step of one octave and a third-stop
// sweep's prior-held error was drawn three times too long.
std::vector<FrameExposureReport> FramesFromJson(const nlohmann::json& j,
                                                const std::string& source) {
  const std::string what = source + ": 'frames' ";
  if (!j.is_array()) throw InputError(what + "must be a list");
  std::vector<FrameExposureReport> out;
  for (const auto& f : j) {
    FrameExposureReport r;
    try {
      r.file = f.at("file").get<std::string>();
      r.listed_s = f.at("listed_exposure_s").get<double>();
      r.estimated_s = f.at("used_exposure_s").get<double>();
      r.consistent = f.value("consistent", true);
      r.used = f.value("used", true);
      r.note = f.value("note", std::string());
    } catch (const nlohmann::json::exception&) {
      throw InputError(what + "needs file, listed_exposure_s and used_exposure_s in each entry");
    }
    if (!(r.listed_s >= 0 && r.estimated_s >= 0) || !std::isfinite(r.listed_s) ||
        !std::isfinite(r.estimated_s)) {
      throw InputError(what + "holds an exposure that is negative or not finite (" + r.file + ")");
    }
    out.push_back(std::move(r));
  }
  return out;
}

// An optional number at `key`: absent or null leaves *value; otherwise it must be finite and
// >= 0 (> 0 when `positive`), or InputError naming the file and key.
void OptionalNumberFromJson(const nlohmann::json& j, const char* key, bool positive,
                            const std::string& source, double* value) {
  if (!j.contains(key) || j[key].is_null()) return;
  const auto& v = j[key];
  const bool ok = v.is_number() && std::isfinite(v.get<double>()) &&
                  (positive ? v.get<double>() > 0 : v.get<double>() >= 0);
  if (!ok) {
    throw InputError(fmt::format("{}: '{}' must be a {} number or null", source, key,
                                 positive ? "positive" : "non-negative"));
  }
  *value = v.get<double>();
}

// The fields every response.json holds: bit depth, black level (with its source and range),
// the table and the saturation level.
void RequiredFromJson(const nlohmann::json& j, const std::string& source, ResponseResult* r) {
  try {
    r->bit_depth = j.at("bit_depth").get<int>();
    // Checked before any shift by it: 1 << 40 is undefined behaviour.
    if (r->bit_depth < 8 || r->bit_depth > 16) {
      throw InputError(source + ": bit_depth must be 8..16, not " + std::to_string(r->bit_depth));
    }
    r->black_level = j.at("black_level").get<std::vector<double>>();
    // Written since the black level can be measured; older files held estimates or options.
    const std::string named = j.value("black_level_source", "estimated");
    bool known = false;
    for (auto b : {BlackLevelSource::kEstimated, BlackLevelSource::kOption,
                   BlackLevelSource::kSession, BlackLevelSource::kDarkFrames,
                   BlackLevelSource::kRawMetadata, BlackLevelSource::kAssumed}) {
      if (named == BlackLevelSourceName(b)) r->black_level_source = b, known = true;
    }
    if (!known) throw InputError(source + ": black_level_source '" + named + "' is unknown");
    r->black_level_range = j.value("black_level_range", std::vector<std::array<double, 2>>());
    r->inverse_response = j.at("inverse_response").get<std::vector<std::vector<double>>>();
    r->channels = static_cast<int>(r->inverse_response.size());
    r->saturation_level =
        j.value("saturation_level", std::vector<double>(r->channels, (1 << r->bit_depth) - 1.0));
  } catch (const nlohmann::json::exception&) {
    throw InputError(source + ": needs bit_depth, black_level and inverse_response");
  }
  if (r->black_level_range.empty()) {
    for (double b : r->black_level) r->black_level_range.push_back({b, b});
  }
}

// The fit's figures. The self-check and the smoothing sensitivity set the response's share of
// the calibration's accuracy (PhotometricCalibration::ResponseAccuracy), so they are read back,
// not dropped; the rest so that a response from its file reports as it did.
void FitFiguresFromJson(const nlohmann::json& j, const std::string& source, ResponseResult* r) {
  if (j.contains("consistency"))
    r->consistency = PairConsistency::FromJson(j["consistency"], source);
  OptionalNumberFromJson(j, "smoothing_sensitivity", false, source, &r->smoothing_sensitivity);
  if (j.contains("smoothing_sensitivity_bands")) {
    r->smoothing_sensitivity_bands = BandsFromJson(j["smoothing_sensitivity_bands"], source);
  }
  if (j.contains("ends")) r->ends = EndsFromJson(j["ends"], r->channels, source);
  if (j.contains("frames")) r->frames = FramesFromJson(j["frames"], source);
  OptionalNumberFromJson(j, "rms_log_residual", false, source, &r->rms_log_residual);
  OptionalNumberFromJson(j, "regional_mapping_difference", false, source,
                         &r->regional_mapping_difference);
  OptionalNumberFromJson(j, "knot_spacing", true, source, &r->knot_spacing);
  if (j.contains("sampled_pixels")) {
    const auto& v = j["sampled_pixels"];
    if (!v.is_number_integer() || v.get<std::int64_t>() < 0 || v.get<std::int64_t>() > INT_MAX) {
      throw InputError(source + ": 'sampled_pixels' must be a whole number >= 0");
    }
    r->sampled_pixels = v.get<int>();
  }
  if (j.contains("bootstrap_ln_change")) {
    r->bootstrap_ln_change = BootstrapFromJson(j["bootstrap_ln_change"], r->channels, source);
    if (!r->bootstrap_ln_change.empty() && !std::isfinite(r->knot_spacing)) {
      throw InputError(source + ": 'bootstrap_ln_change' needs 'knot_spacing'");
    }
  }
}

// Per channel a black level, its range and a finite, non-decreasing table of 2^bit_depth values.
void CheckShape(const ResponseResult& r, const std::string& source) {
  if (r.bit_depth < 8 || r.bit_depth > 16 || r.channels < 1 ||
      static_cast<int>(r.black_level.size()) != r.channels ||
      static_cast<int>(r.black_level_range.size()) != r.channels) {
    throw InputError(source + ": inconsistent bit_depth, black_level and inverse_response");
  }
  for (const auto& t : r.inverse_response) {
    if (static_cast<int>(t.size()) != (1 << r.bit_depth)) {
      throw InputError(source + ": inverse_response needs 2^bit_depth values per channel");
    }
    for (size_t z = 1; z < t.size(); ++z) {
      if (!(t[z] >= t[z - 1]) || !std::isfinite(t[z])) {
        throw InputError(source + ": inverse_response must be finite and non-decreasing");
      }
    }
  }
}

}  // namespace

nlohmann::json ResponseResult::ToJson() const {
  nlohmann::json fr = nlohmann::json::array();
  for (const auto& f : frames) {
    fr.push_back({{"file", f.file},
                  {"listed_exposure_s", f.listed_s},
                  {"used_exposure_s", f.estimated_s},
                  {"consistent", f.consistent},
                  {"used", f.used},
                  {"note", f.note}});
  }
  return {{"bit_depth", bit_depth},
          {"channels", channels},
          {"black_level", black_level},
          {"black_level_source", BlackLevelSourceName(black_level_source)},
          {"black_level_range", black_level_range},
          {"saturation_level", saturation_level},
          {"inverse_response", inverse_response},
          {"frames", fr},
          {"consistency", consistency.ToJson()},
          {"regional_mapping_difference", regional_mapping_difference},
          {"smoothing_sensitivity", std::isfinite(smoothing_sensitivity)
                                        ? nlohmann::json(smoothing_sensitivity)
                                        : nlohmann::json()},
          {"smoothing_sensitivity_bands", NullForNan(smoothing_sensitivity_bands)},
          {"ends", EndsToJson(ends)},
          {"knot_spacing",
           std::isfinite(knot_spacing) ? nlohmann::json(knot_spacing) : nlohmann::json()},
          {"bootstrap_ln_change", bootstrap_ln_change},
          {"sampled_pixels", sampled_pixels},
          {"rms_log_residual", rms_log_residual}};
}

ResponseResult ResponseResult::FromJson(const nlohmann::json& j, const std::string& source) {
  ResponseResult r;
  RequiredFromJson(j, source, &r);
  FitFiguresFromJson(j, source, &r);
  CheckShape(r, source);
  return r;
}

}  // namespace gonio
