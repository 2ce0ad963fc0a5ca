// Reading exposure sweeps and response.json, and what a ResponseResult says of itself
// (calib/response.h); the calibration itself is response.cc.
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/response.h"
#include "common/error.h"

namespace gonio {

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
    f.image = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (f.image.empty()) throw InputError(path + ": cannot be read as an image");
    if (f.image.depth() != CV_8U && f.image.depth() != CV_16U) {
      throw InputError(path + ": only 8- and 16-bit images are supported");
    }
    if (f.image.channels() == 4) cv::cvtColor(f.image, f.image, cv::COLOR_BGRA2BGR);
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

double ResponseResult::Linearize(int channel, double value) const {
  const auto& t = inverse_response.at(channel);
  const double z = std::clamp(value, 0.0, static_cast<double>(t.size() - 1));
  const size_t k = std::min(static_cast<size_t>(z), t.size() - 2);
  const double a = z - k;
  return (1 - a) * t[k] + a * t[k + 1];
}

double ResponseResult::Slope(int channel, double value) const {
  const auto& t = inverse_response.at(channel);
  const size_t k =
      std::min(static_cast<size_t>(std::clamp(value, 0.0, t.size() - 2.0)), t.size() - 2);
  return t[k + 1] - t[k];
}

std::string ResponseResult::Report() const {
  std::ostringstream s;
  s << fmt::format("inverse response: {} channel(s), {} bit, black level", channels, bit_depth);
  for (double b : black_level) s << fmt::format(" {:.1f}", b);
  s << fmt::format("; fit rms {:.4f} (ln units)\n", rms_log_residual);
  s << fmt::format(
      "linearity check: worst neighbouring pair |median ratio - exposure ratio| {:.2f}%\n",
      100 * median_ratio_error);
  for (const auto& f : frames) {
    s << fmt::format(
        "  {:<20} listed {:>10.5g} s  used {:>10.5g} s  {}\n", f.file, f.listed_s, f.estimated_s,
        !f.used ? "left out: " + f.note
                : (f.consistent ? (f.note.empty() ? "ok" : "ok (re-timed: " + f.note + ")")
                                : "re-timed: " + f.note));
  }
  return s.str();
}

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
  nlohmann::json pairs = nlohmann::json::array();
  for (double e : pair_ratio_error)
    pairs.push_back(std::isfinite(e) ? nlohmann::json(e) : nlohmann::json());
  return {
      {"bit_depth", bit_depth},
      {"channels", channels},
      {"black_level", black_level},
      {"saturation_level", saturation_level},
      {"inverse_response", inverse_response},
      {"frames", fr},
      {"median_ratio_error",
       std::isfinite(median_ratio_error) ? nlohmann::json(median_ratio_error) : nlohmann::json()},
      {"pair_ratio_error", pairs},
      {"rms_log_residual", rms_log_residual}};
}

ResponseResult ResponseResult::FromJson(const nlohmann::json& j, const std::string& source) {
  ResponseResult r;
  try {
    r.bit_depth = j.at("bit_depth").get<int>();
    // Checked before any shift by it: 1 << 40 is undefined behaviour.
    if (r.bit_depth < 8 || r.bit_depth > 16) {
      throw InputError(source + ": bit_depth must be 8..16, not " + std::to_string(r.bit_depth));
    }
    r.black_level = j.at("black_level").get<std::vector<double>>();
    r.inverse_response = j.at("inverse_response").get<std::vector<std::vector<double>>>();
    r.channels = static_cast<int>(r.inverse_response.size());
    r.saturation_level =
        j.value("saturation_level", std::vector<double>(r.channels, (1 << r.bit_depth) - 1.0));
  } catch (const nlohmann::json::exception&) {
    throw InputError(source + ": needs bit_depth, black_level and inverse_response");
  }
  if (r.bit_depth < 8 || r.bit_depth > 16 || r.channels < 1 ||
      static_cast<int>(r.black_level.size()) != r.channels) {
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
  return r;
}

}  // namespace gonio
