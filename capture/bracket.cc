#include "capture/bracket.h"

#include <algorithm>
#include <cmath>
#include <regex>
#include <set>

#include <fmt/format.h>

#include "common/error.h"

namespace gonio::capture {

double ParseDuration(const std::string& text, const std::string& what) {
  static const std::regex kRe(
      R"(\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)(?:\s*/\s*([0-9]*\.?[0-9]+))?\s*(s|ms|us|µs|ns)?\s*)");
  std::smatch m;
  if (!std::regex_match(text, m, kRe)) {
    throw InputError(what + ": '" + text + "' is not a duration (e.g. 16ms, 250us, 1/125, 0.5s)");
  }
  double value = std::stod(m[1]);
  if (m[2].matched) {
    const double denominator = std::stod(m[2]);
    if (denominator == 0.0) throw InputError(what + ": '" + text + "' divides by zero");
    value /= denominator;
  }
  const std::string unit = m[3].matched ? m[3].str() : "s";
  const double scale = unit == "s" ? 1.0 : unit == "ms" ? 1e-3 : unit == "ns" ? 1e-9 : 1e-6;
  const double seconds = value * scale;
  if (!std::isfinite(seconds) || seconds <= 0.0) {
    throw InputError(what + ": '" + text + "' is not a positive duration");
  }
  return seconds;
}

std::vector<double> ParseExposureList(const std::string& text, const std::string& what) {
  std::vector<double> out;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const std::string item =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    out.push_back(ParseDuration(item, what));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  std::set<double> seen;
  for (double e : out) {
    if (!seen.insert(e).second) {
      throw InputError(what + ": exposure " + FormatDuration(e) + " is listed twice");
    }
  }
  return out;
}

std::vector<Shot> ScheduleBrackets(const std::vector<double>& exposures_s, int num_brackets) {
  if (exposures_s.empty()) throw InputError("--exposures: no exposure given");
  if (num_brackets < 1) throw InputError("--frames: must be at least 1");
  for (double e : exposures_s) {
    if (!std::isfinite(e) || e <= 0.0) throw InputError("--exposures: exposures must be > 0");
  }
  std::vector<double> ascending = exposures_s;
  std::sort(ascending.begin(), ascending.end());
  std::vector<Shot> shots;
  shots.reserve(ascending.size() * static_cast<size_t>(num_brackets));
  for (int b = 0; b < num_brackets; ++b) {
    for (size_t k = 0; k < ascending.size(); ++k) {
      const size_t i = (b % 2 == 0) ? k : ascending.size() - 1 - k;
      Shot s;
      s.bracket = b;
      s.exposure_s = ascending[i];
      s.exposure_changes = shots.empty() || shots.back().exposure_s != s.exposure_s;
      shots.push_back(s);
    }
  }
  return shots;
}

std::string FormatDuration(double seconds) {
  if (seconds >= 1.0) return fmt::format("{:g} s", seconds);
  if (seconds >= 1e-3) return fmt::format("{:g} ms", seconds * 1e3);
  return fmt::format("{:g} us", seconds * 1e6);
}

}  // namespace gonio::capture
