// Screening of an exposure sweep's listed times (calib/photometry/response_fit.h; the method is
// described in docs/photometric.md "Exposure times").
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "calib/photometry/response_fit.h"
#include "common/error.h"
#include "common/parallel.h"
#include "common/stats.h"

namespace gonio {
namespace {

// Each channel's fit with its own saturation level; `free_time` says which frames are re-timed.
std::vector<ChannelFit> FitChannels(const std::vector<std::vector<cv::Mat>>& planes,
                                    const std::vector<ExposureFrame>& frames,
                                    const std::vector<bool>& free_time, bool times_unknown,
                                    const std::vector<Setup>& setups,
                                    const std::vector<std::vector<cv::Point>>& pixels,
                                    const ResponseOptions& o) {
  std::vector<ChannelFit> fits(planes.size());
  ParallelFor(planes.size(), o.threads, [&](size_t b, size_t e) {
    for (size_t c = b; c < e; ++c) {
      fits[c] = FitChannel(planes[c], frames, free_time, times_unknown, setups[c], pixels[c], o);
    }
  });
  return fits;
}

// The frames whose listed time the others contradict: the frame's offset (median over
// channels) exceeds both the tolerance and three times the curve's own uncertainty, taken as
// the robust spread (1.4826 MAD about 0) of all held frames' offsets; a film's reciprocity or
// a curve error moves every frame a little, a wrong listed time moves one frame a lot. Returns
// the held frame that contradicts most, or -1.
int WorstContradictingFrame(const std::vector<ChannelFit>& fits, const Setup& s,
                            const std::vector<bool>& free_time, const ResponseOptions& o) {
  std::vector<double> offset(free_time.size(), NAN), magnitudes;
  for (int j : s.usable) {
    if (free_time[j]) continue;
    std::vector<double> per_channel;
    for (const auto& f : fits) {
      if (std::isfinite(f.frame_offset[j])) per_channel.push_back(f.frame_offset[j]);
    }
    if (per_channel.empty()) continue;
    offset[j] = Median(per_channel);
    magnitudes.push_back(std::abs(offset[j]));
  }
  if (magnitudes.empty()) return -1;
  const double limit = std::max(std::log1p(o.exposure_tolerance), 3 * 1.4826 * Median(magnitudes));
  int worst = -1;
  for (int j : s.usable) {
    if (std::isfinite(offset[j]) && std::abs(offset[j]) > limit &&
        (worst < 0 || std::abs(offset[j]) > std::abs(offset[worst]))) {
      worst = j;
    }
  }
  return worst;
}

// The frames off the line ln t_fitted = a + b ln t_listed (b > 0) that most frames lie on, with
// the times fitted free of the listed ones (FixGauge's `times_unknown`): every pair of frames
// proposes a line, the one with most frames within `band` (ln units of listed time) wins, ties
// going to the smaller squared residual. Exhaustive, so deterministic.
std::vector<bool> OffTheLine(const std::vector<double>& ln_listed,
                             const std::vector<double>& ln_fit, const std::vector<int>& usable,
                             double band) {
  std::vector<bool> best_out(ln_listed.size(), false);
  int best_in = -1;
  double best_ssr = INFINITY;
  for (int i : usable) {
    for (int k : usable) {
      if (ln_listed[k] <= ln_listed[i] + 1e-9) continue;
      const double b = (ln_fit[k] - ln_fit[i]) / (ln_listed[k] - ln_listed[i]);
      if (b < 0.05) continue;
      const double a = ln_fit[i] - b * ln_listed[i];
      int in = 0;
      double ssr = 0;
      std::vector<bool> out(ln_listed.size(), false);
      for (int j : usable) {
        const double r = (ln_fit[j] - a) / b - ln_listed[j];
        out[j] = std::abs(r) > band;
        if (!out[j]) {
          ++in;
          ssr += r * r;
        }
      }
      if (in > best_in || (in == best_in && ssr < best_ssr)) {
        best_in = in;
        best_ssr = ssr;
        best_out = out;
      }
    }
  }
  return best_out;
}

// Gross contradictions: frames off the line (OffTheLine, twice the tolerance) in at least half
// of the channels. A frame with few well-exposed pixels (nearly all dark or saturated) is not
// judged: its fitted time is poorly determined, and it carries little weight.
std::vector<int> GrosslyWrongFrames(const std::vector<ChannelFit>& fits,
                                    const std::vector<ExposureFrame>& frames, const Setup& s,
                                    const ResponseOptions& o) {
  std::vector<double> ln_listed;
  for (const auto& f : frames) ln_listed.push_back(std::log(f.exposure_s));
  std::vector<int> votes(frames.size(), 0);
  for (const auto& f : fits) {
    std::vector<int> judged;
    for (int j : s.usable) {
      if (f.judgeable[j]) judged.push_back(j);
    }
    const auto out = OffTheLine(ln_listed, f.ln_t, judged, 2 * std::log1p(o.exposure_tolerance));
    for (size_t j = 0; j < out.size(); ++j) votes[j] += out[j];
  }
  std::vector<int> wrong;
  for (int j : s.usable) {
    if (2 * votes[j] >= static_cast<int>(fits.size())) wrong.push_back(j);
  }
  return wrong;
}

// Releases frame j (re-timed, or left out with `drop_inconsistent`); InputError when fewer than
// two frames keep their listed times.
void Release(int j, const ResponseOptions& o, Setup* s, std::vector<bool>* free_time) {
  (*free_time)[j] = true;
  if (o.drop_inconsistent) s->usable.erase(std::find(s->usable.begin(), s->usable.end(), j));
  size_t held = 0;
  for (int k : s->usable) held += !(*free_time)[k];
  if (held < 2) {
    throw InputError(
        "exposure sweep: fewer than two frames agree with their listed exposures; cannot "
        "calibrate (is this one camera with one response?)");
  }
}

}  // namespace

// A first fit with the times unknown finds the frames whose listed time is grossly wrong; then
// fits holding the remaining listed times exactly (which fixes the exponent ambiguity without
// letting a wrong frame bend the curve) release the most contradicting frame until none is left.
std::vector<ChannelFit> FitWithTimeScreening(const std::vector<std::vector<cv::Mat>>& planes,
                                             const std::vector<ExposureFrame>& frames,
                                             const std::vector<Setup>& setups,
                                             const std::vector<std::vector<cv::Point>>& pixels,
                                             const ResponseOptions& o, Setup* s,
                                             std::vector<bool>* free_time) {
  auto fit = [&](bool times_unknown) {
    std::vector<Setup> channel_setups = setups;
    for (auto& cs : channel_setups) cs.usable = s->usable;
    return FitChannels(planes, frames, *free_time, times_unknown, channel_setups, pixels, o);
  };
  for (int j : GrosslyWrongFrames(fit(true), frames, *s, o)) Release(j, o, s, free_time);
  for (;;) {
    auto fits = fit(false);
    const int worst = WorstContradictingFrame(fits, *s, *free_time, o);
    if (worst < 0) return fits;
    Release(worst, o, s, free_time);
  }
}

// The frames' final times (median over channels) and verdicts.
void ReportFrames(const std::vector<ChannelFit>& fits, const std::vector<bool>& free_time,
                  const std::vector<ExposureFrame>& frames, const Setup& s,
                  const ResponseOptions& o, ResponseResult* result) {
  for (size_t j = 0; j < frames.size(); ++j) {
    if (!free_time[j]) continue;
    auto& rep = result->frames[j];
    const bool used = std::find(s.usable.begin(), s.usable.end(), j) != s.usable.end();
    if (!used) {
      rep.used = false;
      rep.consistent = false;
      rep.note = "its brightness contradicts the listed time";
      continue;
    }
    std::vector<double> ln_t;
    for (const auto& f : fits) ln_t.push_back(f.ln_t[j]);
    rep.estimated_s = std::exp(Median(ln_t));
    rep.consistent = std::abs(std::log(rep.estimated_s / frames[j].exposure_s)) <=
                     std::log1p(o.exposure_tolerance);
    rep.note = fmt::format("brightness implies {:.4g} s, listed {:.4g} s", rep.estimated_s,
                           frames[j].exposure_s);
  }
}

namespace {

// log2 of the ratio of neighbouring used frames' times, equal times left out (they say nothing
// about the response; MeasurePairConsistency skips them too).
std::vector<double> ExposureSteps(const ResponseResult& response) {
  std::vector<double> times;
  for (const auto& f : response.frames) {
    if (f.used && f.estimated_s > 0) times.push_back(f.estimated_s);
  }
  std::sort(times.begin(), times.end());
  std::vector<double> octaves;
  for (size_t k = 1; k < times.size(); ++k) {
    if (times[k] / times[k - 1] > 1.01) octaves.push_back(std::log2(times[k] / times[k - 1]));
  }
  return octaves;
}

}  // namespace

double ExposureStepOctaves(const ResponseResult& response) {
  const std::vector<double> octaves = ExposureSteps(response);
  return octaves.empty() ? 1.0 : Median(octaves);
}

double ExposurePeriodOctaves(const ResponseResult& response) {
  const std::vector<double> octaves = ExposureSteps(response);
  if (octaves.empty()) return 1.0;
  const double median = Median(octaves);
  constexpr double kTolerance = 0.03;  // octaves; a camera's shutter holds its steps closer
  for (int k = 1; k <= 6; ++k) {
    const double period = median / k;
    if (std::all_of(octaves.begin(), octaves.end(), [&](double o) {
          const double multiple = std::max(1.0, std::round(o / period));
          return std::abs(o - multiple * period) <= kTolerance;
        })) {
      return period;
    }
  }
  return median;
}

std::string SweepRemedy(double period_octaves) {
  // Irregular steps of whole thirds keep a period of a third, as third stops do.
  if (period_octaves > 0 && period_octaves < 0.4) {
    return fmt::format(
        "a scene with more radiance levels, or RAW frames (the sweep already steps {:.2f} stops)",
        period_octaves);
  }
  return "a sweep in third stops or with steps that are not all equal (gonio photometric "
         "ladder: 14 frames in steps of 2-5 thirds), a scene with more radiance levels, or RAW "
         "frames";
}

}  // namespace gonio
