// The black level of an inverse response (calib/photometry/response.h, docs/photometric.md "Black
// level"): measured on dark frames, stated by session.json or the user, or, failing those,
// estimated from the curve's shape with the range of black levels that estimate cannot tell apart.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "calib/photometry/response_fit.h"
#include "common/error.h"

namespace gonio {
namespace {

// Counts of each value 0 .. 2^bit_depth - 1 of one channel, inside `mask` (empty: everywhere).
std::vector<double> ValueCounts(const cv::Mat& image, int channel, const cv::Mat& mask,
                                int bit_depth) {
  const int bins = 1 << bit_depth;
  const int channels[] = {channel};
  const int sizes[] = {bins};
  const float range[] = {0.0f, static_cast<float>(bins)};
  const float* ranges[] = {range};
  cv::Mat hist;
  cv::calcHist(&image, 1, channels, mask, hist, 1, sizes, ranges);
  return std::vector<double>(hist.begin<float>(), hist.end<float>());
}

// The q-quantile by nearest rank of the values `counts` holds (as common/stats.h Percentile).
double CountsQuantile(const std::vector<double>& counts, double q) {
  double total = 0;
  for (double c : counts) total += c;
  const double rank = std::floor(q * (total - 1) + 0.5);
  double below = 0;
  for (size_t v = 0; v < counts.size(); ++v) {
    below += counts[v];
    if (below > rank) return static_cast<double>(v);
  }
  return static_cast<double>(counts.size() - 1);
}

// A dark frame's black level in one channel: the lowest value when it holds 30 % of the values
// (noise clipped at the pedestal puts about half of them there, and the median would land on
// the pile's edge or just above it), else the median (noise kept on both sides of the pedestal,
// as in RAW data).
double DarkBlack(const std::vector<double>& counts) {
  double total = 0;
  for (double c : counts) total += c;
  const auto lowest = std::find_if(counts.begin(), counts.end(), [](double c) { return c > 0; });
  if (lowest != counts.end() && *lowest >= 0.3 * total) {
    return static_cast<double>(lowest - counts.begin());
  }
  return CountsQuantile(counts, 0.5);
}

}  // namespace

const char* BlackLevelSourceName(BlackLevelSource source) {
  switch (source) {
    case BlackLevelSource::kOption:
      return "option";
    case BlackLevelSource::kSession:
      return "session.json";
    case BlackLevelSource::kDarkFrames:
      return "dark frames";
    case BlackLevelSource::kRawMetadata:
      return "RAW metadata";
    case BlackLevelSource::kAssumed:
      return "assumed";
    case BlackLevelSource::kEstimated:
      break;
  }
  return "estimated";
}

double DarkestValue(const std::vector<ExposureFrame>& frames, int channel, int bit_depth,
                    bool* piled) {
  double darkest = INFINITY;
  if (piled) *piled = false;
  for (const auto& f : frames) {
    const auto counts = ValueCounts(f.image, channel, f.mask, bit_depth);
    double total = 0;
    for (double c : counts) total += c;
    if (total == 0) continue;  // masked everywhere
    const double q = CountsQuantile(counts, 0.001);
    // A spike, not the edge of a dense histogram (a mask cut there makes one of those).
    const size_t v = static_cast<size_t>(q);
    const bool pile =
        counts[v] >= 0.01 * total && (v + 1 == counts.size() || counts[v] >= 2 * counts[v + 1]);
    if (q < darkest || (q == darkest && pile)) {
      if (piled) *piled = pile || (q == darkest && *piled);
      darkest = q;
    }
  }
  return darkest;
}

std::vector<double> MeasureBlackLevel(const std::vector<ExposureFrame>& dark,
                                      const std::vector<ExposureFrame>& frames, int bit_depth) {
  const cv::Mat& first = frames.front().image;
  const double max_value = std::ldexp(1.0, bit_depth) - 1;
  for (const auto& d : dark) {
    if (d.image.size() != first.size() || d.image.type() != first.type()) {
      throw InputError(d.file + ": dark frame's size or type differs from " + frames.front().file);
    }
    double top = 0;
    cv::minMaxLoc(d.image.reshape(1), nullptr, &top);
    if (top > max_value) {
      throw InputError(fmt::format("{}: value {} exceeds bit depth {}", d.file, top, bit_depth));
    }
  }
  std::vector<double> black(first.channels());
  for (int c = 0; c < first.channels(); ++c) {
    const double darkest = DarkestValue(frames, c, bit_depth);
    std::vector<double> all(static_cast<size_t>(max_value) + 1, 0.0);
    for (const auto& d : dark) {
      const auto counts = ValueCounts(d.image, c, cv::Mat(), bit_depth);
      const double b = DarkBlack(counts);
      const double top = CountsQuantile(counts, 0.99);
      if (top > b + 0.1 * max_value) {
        throw InputError(fmt::format(
            "{}: not dark: 1 % of its values in channel {} lie above {:.0f}, {:.0f} % of the range "
            "above its black level {:.0f} (light on the sensor? shoot it with the lens capped)",
            d.file, c, top, 100 * (top - b) / max_value, b));
      }
      if (b > darkest + 0.02 * max_value) {
        throw InputError(fmt::format(
            "{}: not dark: its black level {:.0f} in channel {} lies above the darkest values of "
            "the sweep ({:.0f}), which light can only raise (light leaking past the lens cap?)",
            d.file, b, c, darkest));
      }
      for (size_t v = 0; v < all.size(); ++v) all[v] += counts[v];
    }
    black[c] = DarkBlack(all);
  }
  return black;
}

void ResolveBlackLevel(const ExposureSweep& sweep, std::optional<double> option,
                       const std::vector<ExposureFrame>& frames, int bit_depth,
                       ResponseOptions* o) {
  const double max_value = std::ldexp(1.0, bit_depth) - 1;
  if (option && sweep.black_level && std::abs(*option - *sweep.black_level) > 0.5) {
    throw InputError(fmt::format("--black-level {} contradicts black_level {} in {}", *option,
                                 *sweep.black_level, sweep.session_file));
  }
  const std::pair<std::optional<double>, std::string> stated[] = {
      {option, "--black-level"}, {sweep.black_level, sweep.session_file}};
  for (const auto& [level, by] : stated) {
    if (level && !(*level >= 0 && *level < max_value)) {
      throw InputError(
          fmt::format("{}: black level {} is outside the {}-bit range", by, *level, bit_depth));
    }
  }
  o->black_level.reset();
  o->channel_black_level.clear();
  if (option || sweep.black_level) {
    o->black_level = option ? *option : *sweep.black_level;
    o->black_level_source = option ? BlackLevelSource::kOption : BlackLevelSource::kSession;
  }
  if (sweep.dark_frames.empty()) return;
  const std::vector<double> measured = MeasureBlackLevel(sweep.dark_frames, frames, bit_depth);
  if (o->black_level) {
    for (double m : measured) {
      if (std::abs(m - *o->black_level) > 0.01 * max_value) {
        throw InputError(fmt::format(
            "{}: the dark frames show black level {:.1f}, but {} states {}", sweep.session_file, m,
            option ? "--black-level" : "its black_level", *o->black_level));
      }
    }
    return;  // the stated level, exact where the measurement has noise and quantisation
  }
  o->channel_black_level = measured;
  o->black_level_source = BlackLevelSource::kDarkFrames;
}

BlackLevelEstimate EstimateBlackLevel(const std::vector<double>& h,
                                      const std::vector<double>& counts, double rms, const Setup& s,
                                      double z_lo, double z_hi) {
  const int K = s.num_knots;
  auto ln_x = [&](double z) { return KnotCurveAt(s, h, z); };
  // Near the dark end a response behaves like a power law, X = c (Z - black)^p (p = 1 for a
  // linear sensor, p ~ 2.2 for a gamma curve): choose the black level whose log-log fit over
  // the lowest supported fifth of the range is straightest.
  const double z_top = z_lo + 0.2 * (z_hi - z_lo);
  std::vector<double> zs, lx;
  double noise = 0;  // sum over the points of the variance of their ln X
  for (int k = 0; k < K; ++k) {
    const double z = static_cast<double>(k) * s.max_value / (K - 1);
    if (z >= z_lo && z <= z_top && counts[k] >= 1.0) {
      zs.push_back(z);
      lx.push_back(ln_x(z));
      noise += rms * rms / counts[k];
    }
  }
  const int steps = 200;
  const double b_max = z_lo - 0.5;
  std::vector<double> bs, sses;
  for (int i = 0; i < steps && zs.size() >= 3; ++i) {
    const double b = b_max * i / steps;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    const double n = zs.size();
    for (size_t q = 0; q < zs.size(); ++q) {
      const double u = std::log(zs[q] - b);
      sx += u;
      sy += lx[q];
      sxx += u * u;
      sxy += u * lx[q];
    }
    const double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    const double icpt = (sy - slope * sx) / n;
    double sse = 0;
    for (size_t q = 0; q < zs.size(); ++q) {
      const double e = icpt + slope * std::log(zs[q] - b) - lx[q];
      sse += e * e;
    }
    bs.push_back(b);
    sses.push_back(sse);
  }
  if (bs.empty()) return {0.0, 0.0, std::max(0.0, b_max)};  // too few points: anything below

  const size_t best = std::min_element(sses.begin(), sses.end()) - sses.begin();
  // Indistinguishable from the best: a sum of squares within 4 variances of one point (two
  // standard deviations of one parameter) of the least, the variance being the larger of the
  // fit's own noise and the best line's misfit.
  const double n = zs.size();
  const double variance = std::max(noise / n, sses[best] / std::max(n - 3, 1.0));
  BlackLevelEstimate e{bs[best], bs[best], bs[best]};
  for (size_t i = 0; i < bs.size(); ++i) {
    if (sses[i] <= sses[best] + 4 * variance) {
      e.lo = std::min(e.lo, bs[i]);
      e.hi = std::max(e.hi, bs[i]);
    }
  }
  // Light only adds: the black level lies at or below the darkest values the sweep holds, and a
  // pipeline that clips at its pedestal piles values up there (an sRGB camera with black level
  // 64 at 8 bits: darkest 64, straightest power law at 48). The shape cannot tell which, so the
  // range covers both. The estimate itself stays the straightest power law: capped at the
  // darkest value it made the real sweeps' self-check worse (desktop 10.4 -> 12.0 % median
  // pair, their darkest values are 0), their tone curves have toes that no black level models.
  if (std::isfinite(s.darkest_value)) {
    e.lo = std::min(e.lo, s.darkest_value);
    e.hi = std::max(e.hi, s.darkest_value);
    // A pile of values (1 % of a frame, twice the next value's) on the darkest value above the
    // straightest power law's black, with nothing between them: the pipeline clips there, no
    // exposure gives less, so it is the black level of the table (the sRGB camera with black 64: 48
    // -> 64). Real sweeps that pile up on 0 keep their estimate.
    if (s.darkest_piled && s.darkest_value > e.value) e.value = s.darkest_value;
  }
  return e;
}

}  // namespace gonio
