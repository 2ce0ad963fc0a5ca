#include "capture/bracket.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <numeric>
#include <optional>
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

namespace {

// "A..B:N" -> the ladder; nullopt for anything else.
std::optional<std::vector<double>> ParseLadder(const std::string& text, const std::string& what) {
  static const std::regex kRe(R"(\s*([^.:,][^,:]*?)\s*\.\.\s*([^,:]+?)\s*:\s*([0-9]+)\s*)");
  std::smatch m;
  if (!std::regex_match(text, m, kRe)) return std::nullopt;
  if (m[3].length() > 4) throw InputError(what + ": '" + text + "' asks for too many frames");
  return IrregularLadder(ParseDuration(m[1], what), ParseDuration(m[2], what), std::stoi(m[3]),
                         what);
}

// Camera shutter speeds in third stops, 2^(k/3) s for k = kFirstThird .. (nominal names).
constexpr int kFirstThird = -39;
constexpr const char* kSpeedNames[] = {
    "1/8000", "1/6400", "1/5000", "1/4000", "1/3200", "1/2500", "1/2000", "1/1600",
    "1/1250", "1/1000", "1/800",  "1/640",  "1/500",  "1/400",  "1/320",  "1/250",
    "1/200",  "1/160",  "1/125",  "1/100",  "1/80",   "1/60",   "1/50",   "1/40",
    "1/30",   "1/25",   "1/20",   "1/15",   "1/13",   "1/10",   "1/8",    "1/6",
    "1/5",    "1/4",    "0.3",    "0.4",    "0.5",    "0.6",    "0.8",    "1",
    "1.3",    "1.6",    "2",      "2.5",    "3.2",    "4",      "5",      "6",
    "8",      "10",     "13",     "15",     "20",     "25",     "30"};

// The largest factor common to every gap between consecutive positions.
int GapGcd(const std::vector<int>& at) {
  int common = 0;
  for (size_t j = 1; j < at.size(); ++j) common = std::gcd(common, at[j] - at[j - 1]);
  return common;
}

}  // namespace

std::vector<double> IrregularLadder(double shortest_s, double longest_s, int frames,
                                    const std::string& what) {
  if (!(shortest_s > 0) || !(longest_s > 0) || !std::isfinite(shortest_s) ||
      !std::isfinite(longest_s)) {
    throw InputError(what + ": the ladder's exposures must be positive");
  }
  if (frames < 3) throw InputError(what + ": a ladder needs at least 3 frames");
  const int first = static_cast<int>(std::lround(3 * std::log2(shortest_s)));
  const int thirds = static_cast<int>(std::lround(3 * std::log2(longest_s))) - first;
  if (thirds < frames - 1) {
    throw InputError(fmt::format(
        "{}: {} frames need at least {} thirds of a stop between the shortest and the longest "
        "exposure ({} to {} holds {})",
        what, frames, frames - 1, FormatDuration(shortest_s), FormatDuration(longest_s),
        std::max(thirds, 0)));
  }
  // Positions in thirds: the even spacing jittered by up to a quarter gap either way with the
  // golden-ratio sequence, kept strictly increasing and inside the range.
  const double gap = static_cast<double>(thirds) / (frames - 1);
  std::vector<int> at(frames, 0);
  at.back() = thirds;
  for (int j = 1; j + 1 < frames; ++j) {
    const double jitter = std::fmod(j * 0.6180339887498949, 1.0) - 0.5;
    const int want = static_cast<int>(std::lround(j * gap + 0.5 * gap * jitter));
    at[j] = std::clamp(want, at[j - 1] + 1, thirds - (frames - 1 - j));
  }
  // Gaps with a common factor (all equal whole stops, say) leave its period free: move one
  // interior frame by a third or two until they have none.
  for (int j = 1; GapGcd(at) > 1 && j + 1 < frames; ++j) {
    for (int delta : {-1, 1, -2, 2}) {
      const int was = at[j];
      at[j] += delta;
      if (at[j] > at[j - 1] && at[j] < at[j + 1] && GapGcd(at) == 1) break;
      at[j] = was;
    }
  }
  std::vector<double> out;
  for (int k : at) out.push_back(std::exp2((first + k) / 3.0));
  return out;
}

std::string ShutterSpeedName(double seconds) {
  if (!(seconds > 0)) return "";
  const long k = std::lround(3 * std::log2(seconds)) - kFirstThird;
  if (k < 0 || k >= static_cast<long>(std::size(kSpeedNames))) return "";
  return kSpeedNames[k];
}

std::vector<double> ParseExposureList(const std::string& text, const std::string& what) {
  if (auto ladder = ParseLadder(text, what)) return *ladder;
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
