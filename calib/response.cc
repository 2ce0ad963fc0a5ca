#include "calib/response.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "common/error.h"
#include "common/parallel.h"
#include "common/stats.h"

namespace gonio {
namespace {

// w * (h(Z) - ln E_p - ln t_j) with h linear between knots k and k+1.
struct ObservationResidual {
  double a, w;
  template <typename T>
  bool operator()(const T* hk, const T* hk1, const T* ln_e, const T* ln_t, T* r) const {
    r[0] = T(w) * ((T(1.0 - a)) * hk[0] + T(a) * hk1[0] - ln_e[0] - ln_t[0]);
    return true;
  }
};

struct SmoothnessResidual {
  double w;
  template <typename T>
  bool operator()(const T* h0, const T* h1, const T* h2, T* r) const {
    r[0] = T(w) * (h0[0] - T(2) * h1[0] + h2[0]);
    return true;
  }
};

struct PriorResidual {
  double ln_listed, inv_sigma;
  template <typename T>
  bool operator()(const T* ln_t, T* r) const {
    r[0] = T(inv_sigma) * (ln_t[0] - T(ln_listed));
    return true;
  }
};

// Pool-adjacent-violators: the weighted least-squares monotone non-decreasing fit.
std::vector<double> Isotonic(const std::vector<double>& y, const std::vector<double>& w) {
  std::vector<double> level, weight;
  std::vector<int> count;
  for (size_t i = 0; i < y.size(); ++i) {
    level.push_back(y[i]);
    weight.push_back(w[i]);
    count.push_back(1);
    while (level.size() > 1 && level[level.size() - 2] > level.back()) {
      const size_t n = level.size();
      const double wsum = weight[n - 2] + weight[n - 1];
      level[n - 2] = (level[n - 2] * weight[n - 2] + level[n - 1] * weight[n - 1]) / wsum;
      weight[n - 2] = wsum;
      count[n - 2] += count[n - 1];
      level.pop_back();
      weight.pop_back();
      count.pop_back();
    }
  }
  std::vector<double> out;
  for (size_t b = 0; b < level.size(); ++b) out.insert(out.end(), count[b], level[b]);
  return out;
}

struct ChannelFit {
  std::vector<double> h;       // knots
  std::vector<double> ln_t;    // per frame
  std::vector<double> counts;  // observations per knot (for the isotonic weights)
  double rms = 0;
};

struct Setup {
  int bit_depth, max_value, num_knots;
  double dark_limit, saturation_limit;
  std::vector<int> usable;  // frame indices in the fit
};

double KnotPosition(const Setup& s, double z) { return z / s.max_value * (s.num_knots - 1); }

double HatWeight(const Setup& s, double z) {
  if (z <= s.dark_limit || z >= s.saturation_limit) return 0.0;
  const double half = 0.5 * (s.saturation_limit - s.dark_limit);
  return std::min(z - s.dark_limit, s.saturation_limit - z) / half;
}

// Pixels on flat areas (small gradient, robust to tiny misalignment), stratified by their mean
// normalized value so that dark and bright scene parts are both represented.
std::vector<cv::Point> SamplePixels(const std::vector<cv::Mat>& planes, const Setup& s,
                                    int wanted) {
  const cv::Mat& ref = planes[s.usable[s.usable.size() / 2]];
  cv::Mat blurred, gx, gy, grad;
  ref.convertTo(blurred, CV_32F);
  cv::GaussianBlur(blurred, blurred, cv::Size(5, 5), 1.5);
  cv::Sobel(blurred, gx, CV_32F, 1, 0);
  cv::Sobel(blurred, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, grad);
  const int stride = std::max(2, static_cast<int>(std::sqrt(ref.total() / (8.0 * wanted))));
  struct Candidate {
    cv::Point p;
    float gradient;
    double mean;
  };
  std::vector<Candidate> cands;
  for (int y = 4; y < ref.rows - 4; y += stride) {
    for (int x = 4; x < ref.cols - 4; x += stride) {
      double mean = 0;
      for (int j : s.usable) mean += planes[j].at<float>(y, x);
      cands.push_back({{x, y}, grad.at<float>(y, x), mean / s.usable.size()});
    }
  }
  std::vector<float> g;
  for (const auto& c : cands) g.push_back(c.gradient);
  std::nth_element(g.begin(), g.begin() + g.size() / 2, g.end());
  const float gradient_limit = g[g.size() / 2];
  const int bins = 32;
  std::vector<std::vector<cv::Point>> strata(bins);
  for (const auto& c : cands) {
    if (c.gradient > gradient_limit) continue;
    const int b = std::clamp(static_cast<int>(c.mean / (s.max_value + 1.0) * bins), 0, bins - 1);
    strata[b].push_back(c.p);
  }
  std::vector<cv::Point> picked;
  for (int round = 0; static_cast<int>(picked.size()) < wanted; ++round) {
    bool any = false;
    for (auto& st : strata) {
      // Deterministic spread within a stratum: take every (size / per-round)th element.
      if (round < static_cast<int>(st.size())) {
        const size_t idx = (static_cast<size_t>(round) * 7919) % st.size();
        picked.push_back(st[idx]);
        any = true;
      }
      if (static_cast<int>(picked.size()) >= wanted) break;
    }
    if (!any) break;
  }
  std::sort(picked.begin(), picked.end(), [](const cv::Point& a, const cv::Point& b) {
    return a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  picked.erase(std::unique(picked.begin(), picked.end()), picked.end());
  return picked;
}

// Where value z falls between knots: h(z) = (1 - a) h[k] + a h[k + 1].
struct KnotPair {
  int k;
  double a;
};

KnotPair KnotsOf(const Setup& s, double z) {
  const double pos = KnotPosition(s, z);
  const int k = std::min(static_cast<int>(pos), s.num_knots - 2);
  return {k, pos - k};
}

// One residual per well-exposed observation of a sampled pixel; each pixel's ln E starts at
// the median over its frames of h(Z) - ln t. Returns the number of observations.
size_t AddObservations(const std::vector<cv::Mat>& planes, const Setup& s,
                       const std::vector<cv::Point>& pixels, ceres::Problem* problem,
                       ChannelFit* fit, std::vector<double>* ln_e) {
  size_t n_obs = 0;
  for (size_t p = 0; p < pixels.size(); ++p) {
    std::vector<double> est;
    for (int j : s.usable) {
      const double z = planes[j].at<float>(pixels[p]);
      const double w = HatWeight(s, z);
      if (w < 0.05) continue;
      const auto [k, a] = KnotsOf(s, z);
      est.push_back((1 - a) * fit->h[k] + a * fit->h[k + 1] - fit->ln_t[j]);
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<ObservationResidual, 1, 1, 1, 1, 1>(
                                    new ObservationResidual{a, w}),
                                nullptr, &fit->h[k], &fit->h[k + 1], &(*ln_e)[p], &fit->ln_t[j]);
      fit->counts[k] += w * (1 - a);
      fit->counts[k + 1] += w * a;
      ++n_obs;
    }
    (*ln_e)[p] = est.empty() ? 0.0 : Median(est);
  }
  return n_obs;
}

// Second differences of h, weighted by the hat function as in Debevec-Malik: ln X curves
// hardest near the dark end, where a uniform penalty would bias it.
void AddSmoothness(const Setup& s, double weight, ceres::Problem* problem, ChannelFit* fit) {
  const int K = s.num_knots;
  for (int k = 1; k + 1 < K; ++k) {
    const double z = static_cast<double>(k) * s.max_value / (K - 1);
    const double w = weight * std::max(0.05, HatWeight(s, z));
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<SmoothnessResidual, 1, 1, 1, 1>(new SmoothnessResidual{w}),
        nullptr, &fit->h[k - 1], &fit->h[k], &fit->h[k + 1]);
  }
}

// Exposure priors with a heavy-tailed loss (see the header); a frame without a trusted time
// floats freely, a trusted one is held exactly when `times_fixed`.
void AddExposurePriors(const std::vector<double>& listed, const std::vector<bool>& has_prior,
                       bool times_fixed, const Setup& s, double prior_sigma,
                       ceres::Problem* problem, ChannelFit* fit) {
  for (int j : s.usable) {
    if (!problem->HasParameterBlock(&fit->ln_t[j])) continue;
    if (times_fixed && has_prior[j]) {
      problem->SetParameterBlockConstant(&fit->ln_t[j]);
    } else if (has_prior[j]) {
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PriorResidual, 1, 1>(
                                    new PriorResidual{std::log(listed[j]), 1.0 / prior_sigma}),
                                new ceres::CauchyLoss(1.0), &fit->ln_t[j]);
    }
  }
}

// RMS of h(Z) - ln E - ln t over the well-exposed observations.
double ObservationRms(const std::vector<cv::Mat>& planes, const Setup& s,
                      const std::vector<cv::Point>& pixels, const ChannelFit& fit,
                      const std::vector<double>& ln_e) {
  double ssr = 0;
  size_t m = 0;
  for (size_t p = 0; p < pixels.size(); ++p) {
    for (int j : s.usable) {
      const double z = planes[j].at<float>(pixels[p]);
      if (HatWeight(s, z) < 0.05) continue;
      const auto [k, a] = KnotsOf(s, z);
      const double r = (1 - a) * fit.h[k] + a * fit.h[k + 1] - ln_e[p] - fit.ln_t[j];
      ssr += r * r;
      ++m;
    }
  }
  return std::sqrt(ssr / std::max<size_t>(m, 1));
}

ChannelFit FitChannel(const std::vector<cv::Mat>& planes, const std::vector<double>& listed,
                      const std::vector<bool>& has_prior, bool times_fixed, const Setup& s,
                      const std::vector<cv::Point>& pixels, const ResponseOptions& o) {
  const int K = s.num_knots;
  ChannelFit fit;
  fit.h.resize(K);
  for (int k = 0; k < K; ++k) fit.h[k] = std::log((k + 0.5) / K);  // start: linear response
  fit.ln_t.assign(listed.size(), 0.0);
  for (size_t j = 0; j < listed.size(); ++j) fit.ln_t[j] = std::log(listed[j]);
  fit.counts.assign(K, 0.0);
  std::vector<double> ln_e(pixels.size(), 0.0);

  ceres::Problem problem;
  const size_t n_obs = AddObservations(planes, s, pixels, &problem, &fit, &ln_e);
  if (n_obs == 0) {
    throw InputError("exposure sweep: no pixel is well exposed in any frame");
  }
  AddSmoothness(s, o.smoothness * std::sqrt(static_cast<double>(n_obs) / K), &problem, &fit);
  AddExposurePriors(listed, has_prior, times_fixed, s, o.prior_sigma, &problem, &fit);
  // Additive gauge of (h, ln E): h = 0 at the middle knot.
  problem.SetParameterBlockConstant(&fit.h[K / 2]);
  fit.h[K / 2] = 0.0;
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  so.max_num_iterations = 100;
  so.logging_type = ceres::SILENT;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    throw NumericalError("response fit failed: " + summary.message);
  }
  fit.rms = ObservationRms(planes, s, pixels, fit, ln_e);
  return fit;
}

// Table of relative exposure for every value: exp(h) where data exist, a straight line down to
// the black level below, held constant at and above saturation.
std::vector<double> BuildTable(const ChannelFit& fit, const Setup& s, double* black_level,
                               bool black_given) {
  const int K = s.num_knots;
  std::vector<double> w(K);
  for (int k = 0; k < K; ++k) w[k] = fit.counts[k] + 1e-6;
  const std::vector<double> h = Isotonic(fit.h, w);
  auto X = [&](double z) {
    const double pos = KnotPosition(s, z);
    const int k = std::clamp(static_cast<int>(pos), 0, K - 2);
    const double a = pos - k;
    return std::exp((1 - a) * h[k] + a * h[k + 1]);
  };
  // Lowest and highest values the data support.
  int k_lo = 0, k_hi = K - 1;
  while (k_lo < K - 1 && fit.counts[k_lo] < 1.0) ++k_lo;
  while (k_hi > 0 && fit.counts[k_hi] < 1.0) --k_hi;
  const double z_lo = std::max(static_cast<double>(k_lo) * s.max_value / (K - 1), s.dark_limit);
  const double z_hi =
      std::min(static_cast<double>(k_hi) * s.max_value / (K - 1), s.saturation_limit);
  if (!black_given) {
    // Near the dark end a response behaves like a power law, X = c (Z - black)^p (p = 1 for a
    // linear sensor, p ~ 2.2 for a gamma curve): choose the black level whose log-log fit over
    // the lowest supported fifth of the range is straightest.
    const double z_top = z_lo + 0.2 * (z_hi - z_lo);
    std::vector<double> zs, lx;
    for (int k = 0; k < K; ++k) {
      const double z = static_cast<double>(k) * s.max_value / (K - 1);
      if (z >= z_lo && z <= z_top && fit.counts[k] >= 1.0) {
        zs.push_back(z);
        lx.push_back(std::log(X(z)));
      }
    }
    double best_b = 0.0, best_sse = INFINITY;
    const int steps = 200;
    for (int i = 0; i < steps && zs.size() >= 3; ++i) {
      const double b = (z_lo - 0.5) * i / steps;
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
      if (sse < best_sse) {
        best_sse = sse;
        best_b = b;
      }
    }
    *black_level = best_b;
  }
  std::vector<double> table(s.max_value + 1);
  const double x_lo = X(z_lo), x_hi = X(z_hi);
  for (int z = 0; z <= s.max_value; ++z) {
    double x;
    if (z < z_lo) {
      x = z <= *black_level ? 0.0 : x_lo * (z - *black_level) / (z_lo - *black_level);
    } else if (z > z_hi) {
      x = x_hi;
    } else {
      x = X(z);
    }
    table[z] = x / x_hi;  // relative exposure 1 at the highest reliable value
  }
  // Guard the monotone contract against rounding at the joins.
  for (int z = 1; z <= s.max_value; ++z) table[z] = std::max(table[z], table[z - 1]);
  return table;
}

std::vector<cv::Mat> SplitToFloat(const cv::Mat& image) {
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  for (auto& p : planes) p.convertTo(p, CV_32F);
  return planes;
}

// InputError unless the frames share size and type, have exposure times > 0, and differ in
// exposure.
void CheckSweep(const std::vector<ExposureFrame>& frames) {
  if (frames.size() < 2) throw InputError("an exposure sweep needs at least two frames");
  const cv::Mat& first = frames[0].image;
  for (const auto& f : frames) {
    if (f.image.empty()) throw InputError(f.file + ": empty image");
    if (f.image.size() != first.size() || f.image.type() != first.type()) {
      throw InputError(f.file + ": size or type differs from " + frames[0].file);
    }
    if (!(f.exposure_s > 0)) throw InputError(f.file + ": exposure time must be > 0");
  }
  double min_t = INFINITY, max_t = 0;
  for (const auto& f : frames) {
    min_t = std::min(min_t, f.exposure_s);
    max_t = std::max(max_t, f.exposure_s);
  }
  if (max_t <= min_t * 1.01) throw InputError("exposure sweep: all frames have the same exposure");
}

Setup MakeSetup(const ResponseOptions& o, const cv::Mat& first) {
  Setup s;
  s.bit_depth = o.bit_depth ? o.bit_depth : (first.depth() == CV_8U ? 8 : 16);
  s.max_value = (1 << s.bit_depth) - 1;
  s.num_knots = std::min(o.num_knots, s.max_value + 1);
  s.saturation_limit = s.max_value * (1.0 - o.saturation_margin);
  s.dark_limit = (o.black_level ? *o.black_level : 0.0) + 0.02 * s.max_value;
  return s;
}

// planes[channel][frame] as CV_32F; InputError for a value beyond the bit depth.
std::vector<std::vector<cv::Mat>> ChannelPlanes(const std::vector<ExposureFrame>& frames,
                                                const Setup& s, int channels) {
  std::vector<std::vector<cv::Mat>> planes(channels);
  for (const auto& f : frames) {
    double maxv = 0;
    cv::minMaxLoc(f.image.reshape(1), nullptr, &maxv);
    if (maxv > s.max_value) {
      throw InputError(fmt::format("{}: value {} exceeds bit depth {}", f.file, maxv, s.bit_depth));
    }
    const auto split = SplitToFloat(f.image);
    for (int c = 0; c < channels; ++c) planes[c].push_back(split[c]);
  }
  return planes;
}

// One report per frame; frames that carry no information (saturated or dark everywhere) are
// left out, the others listed in s->usable. InputError when fewer than two remain.
void ScreenFrames(const std::vector<ExposureFrame>& frames, const std::vector<cv::Mat>& gray,
                  Setup* s, ResponseResult* result) {
  for (size_t j = 0; j < frames.size(); ++j) {
    FrameExposureReport rep;
    rep.file = frames[j].file;
    rep.listed_s = rep.estimated_s = frames[j].exposure_s;
    const double n = static_cast<double>(gray[j].total());
    const double sat = cv::countNonZero(gray[j] >= s->saturation_limit) / n;
    const double dark = cv::countNonZero(gray[j] <= s->dark_limit) / n;
    if (sat > 0.99) {
      rep.used = false;
      rep.note = "saturated everywhere";
    } else if (dark > 0.99) {
      rep.used = false;
      rep.note = "dark everywhere";
    } else {
      s->usable.push_back(static_cast<int>(j));
    }
    result->frames.push_back(rep);
  }
  if (s->usable.size() < 2) {
    std::string bad;
    for (const auto& r : result->frames) {
      if (!r.used) bad += (bad.empty() ? "" : ", ") + r.file + " (" + r.note + ")";
    }
    throw InputError("exposure sweep: fewer than two usable frames; " + bad);
  }
}

// The exposure times and which of them are trusted, shared by the channels' fits.
struct SweepTimes {
  std::vector<double> listed;
  std::vector<bool> has_prior;
};

std::vector<ChannelFit> FitChannels(const std::vector<std::vector<cv::Mat>>& planes,
                                    const SweepTimes& times, bool times_fixed, const Setup& s,
                                    const std::vector<std::vector<cv::Point>>& pixels,
                                    const ResponseOptions& o) {
  std::vector<ChannelFit> fits(planes.size());
  ParallelFor(planes.size(), o.threads, [&](size_t b, size_t e) {
    for (size_t c = b; c < e; ++c) {
      fits[c] = FitChannel(planes[c], times.listed, times.has_prior, times_fixed, s, pixels[c], o);
    }
  });
  return fits;
}

// Pass 1's verdict: the usable frames whose fitted time (median over channels) departs from
// the listed one by more than the tolerance are marked inconsistent and returned.
std::vector<int> FindInconsistentFrames(const std::vector<ChannelFit>& fits, const Setup& s,
                                        const SweepTimes& times, const ResponseOptions& o,
                                        ResponseResult* result) {
  std::vector<int> inconsistent;
  for (int j : s.usable) {
    std::vector<double> ln_ratio;
    for (const auto& f : fits) ln_ratio.push_back(f.ln_t[j] - std::log(times.listed[j]));
    const double r = Median(ln_ratio);
    if (std::abs(r) > std::log1p(o.exposure_tolerance)) {
      auto& rep = result->frames[j];
      rep.consistent = false;
      rep.note = fmt::format("brightness implies {:.4g} s, listed {:.4g} s",
                             times.listed[j] * std::exp(r), times.listed[j]);
      inconsistent.push_back(j);
    }
  }
  const size_t consistent = s.usable.size() - inconsistent.size();
  if (consistent < 2) {
    throw InputError(fmt::format(
        "exposure sweep: only {} frame(s) agree with their listed exposure; cannot calibrate",
        consistent));
  }
  return inconsistent;
}

// Pass 2's frames: the inconsistent ones lose their prior and are re-timed jointly, or are
// left out with `drop_inconsistent`.
void ReleaseInconsistentFrames(const std::vector<int>& inconsistent, const ResponseOptions& o,
                               Setup* s, SweepTimes* times, ResponseResult* result) {
  std::vector<int> usable;
  for (int j : s->usable) {
    if (std::find(inconsistent.begin(), inconsistent.end(), j) == inconsistent.end()) {
      usable.push_back(j);
    }
  }
  for (int j : inconsistent) {
    times->has_prior[j] = false;
    if (o.drop_inconsistent) {
      result->frames[j].used = false;
    } else {
      usable.push_back(j);
    }
  }
  std::sort(usable.begin(), usable.end());
  s->usable = usable;
}

// The re-timed frames' final times (median over channels) and verdicts: pass 1's robust
// estimate is only a screen; the verdict uses the final estimate.
void ReportRetimedFrames(const std::vector<ChannelFit>& fits, const std::vector<int>& inconsistent,
                         const SweepTimes& times, const ResponseOptions& o,
                         ResponseResult* result) {
  if (o.drop_inconsistent) return;
  for (int j : inconsistent) {
    std::vector<double> ln_t;
    for (const auto& f : fits) ln_t.push_back(f.ln_t[j]);
    auto& rep = result->frames[j];
    rep.estimated_s = std::exp(Median(ln_t));
    rep.consistent =
        std::abs(std::log(rep.estimated_s / times.listed[j])) <= std::log1p(o.exposure_tolerance);
    rep.note = fmt::format("brightness implies {:.4g} s, listed {:.4g} s", rep.estimated_s,
                           times.listed[j]);
  }
}

// The per-channel tables, black and saturation levels, fit RMS and the linearity check.
void FinishResponse(const std::vector<ExposureFrame>& frames, const std::vector<ChannelFit>& fits,
                    const Setup& s, const ResponseOptions& o, ResponseResult* result) {
  result->black_level.assign(result->channels, o.black_level.value_or(0.0));
  result->saturation_level.assign(result->channels, s.saturation_limit);
  double rms = 0;
  for (int c = 0; c < result->channels; ++c) {
    result->inverse_response.push_back(
        BuildTable(fits[c], s, &result->black_level[c], o.black_level.has_value()));
    rms += fits[c].rms * fits[c].rms;
  }
  result->rms_log_residual = std::sqrt(rms / result->channels);
  std::vector<double> used_t(frames.size());
  std::vector<bool> used(frames.size());
  for (size_t j = 0; j < frames.size(); ++j) {
    used[j] = result->frames[j].used;
    used_t[j] = result->frames[j].estimated_s;
  }
  result->median_ratio_error =
      MedianRatioError(frames, used_t, used, result->inverse_response, result->saturation_level,
                       result->black_level, s.bit_depth, &result->pair_ratio_error);
}

}  // namespace

void ResponseOptions::Check() const {
  if (bit_depth != 0 && (bit_depth < 8 || bit_depth > 16)) {
    throw InputError("bit depth must be between 8 and 16");
  }
  if (black_level && !(*black_level >= 0)) throw InputError("black level must be >= 0");
  if (num_knots < 8 || num_knots > 4096) throw InputError("knots must be in [8, 4096]");
  if (num_pixels < 50) throw InputError("at least 50 pixels are needed");
  if (!(smoothness >= 0)) throw InputError("smoothness must be >= 0");
  if (!(prior_sigma > 0)) throw InputError("prior sigma must be > 0");
  if (!(exposure_tolerance > 0)) throw InputError("exposure tolerance must be > 0");
  if (!(saturation_margin >= 0 && saturation_margin < 0.5)) {
    throw InputError("saturation margin must be in [0, 0.5)");
  }
}

ResponseResult CalibrateResponse(const std::vector<ExposureFrame>& frames,
                                 const ResponseOptions& o) {
  o.Check();
  CheckSweep(frames);
  Setup s = MakeSetup(o, frames[0].image);
  ResponseResult result;
  result.bit_depth = s.bit_depth;
  result.channels = frames[0].image.channels();
  const auto planes = ChannelPlanes(frames, s, result.channels);
  ScreenFrames(frames, planes[0], &s, &result);

  SweepTimes times;
  for (const auto& f : frames) times.listed.push_back(f.exposure_s);
  times.has_prior.assign(frames.size(), true);
  std::vector<std::vector<cv::Point>> pixels(result.channels);
  for (int c = 0; c < result.channels; ++c) pixels[c] = SamplePixels(planes[c], s, o.num_pixels);
  // Pass 1: every frame, listed times as robust priors, to find the frames whose brightness
  // contradicts their listed time.
  auto fits = FitChannels(planes, times, false, s, pixels, o);
  const std::vector<int> inconsistent = FindInconsistentFrames(fits, s, times, o, &result);
  // Pass 2: the consistent frames' times are held exactly, so they alone fix the exponent
  // ambiguity.
  ReleaseInconsistentFrames(inconsistent, o, &s, &times, &result);
  fits = FitChannels(planes, times, true, s, pixels, o);
  ReportRetimedFrames(fits, inconsistent, times, o, &result);
  FinishResponse(frames, fits, s, o, &result);
  return result;
}

double MedianRatioError(const std::vector<ExposureFrame>& frames,
                        const std::vector<double>& exposures_s, const std::vector<bool>& used,
                        const std::vector<std::vector<double>>& inverse_response,
                        const std::vector<double>& saturation_level,
                        const std::vector<double>& black_level, int bit_depth,
                        std::vector<double>* per_pair) {
  std::vector<int> order;
  for (size_t j = 0; j < frames.size(); ++j) {
    if (used[j]) order.push_back(static_cast<int>(j));
  }
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return exposures_s[a] < exposures_s[b]; });
  const int channels = frames[0].image.channels();
  double worst = NAN;
  if (per_pair) per_pair->clear();
  for (size_t q = 0; q + 1 < order.size(); ++q) {
    const int a = order[q], b = order[q + 1];
    const double expected = exposures_s[a] / exposures_s[b];
    if (expected > 0.99) continue;  // equal exposures say nothing about the response
    std::vector<cv::Mat> pa, pb;
    cv::split(frames[a].image, pa);
    cv::split(frames[b].image, pb);
    std::vector<double> ratios;
    for (int c = 0; c < channels; ++c) {
      const double lo = black_level[c] + 0.1 * (saturation_level[c] - black_level[c]);
      const double hi = saturation_level[c] - 0.1 * (saturation_level[c] - black_level[c]);
      cv::Mat fa, fb;
      pa[c].convertTo(fa, CV_32S);
      pb[c].convertTo(fb, CV_32S);
      for (int y = 0; y < fa.rows; y += 3) {
        for (int x = 0; x < fa.cols; x += 3) {
          const int za = fa.at<int>(y, x), zb = fb.at<int>(y, x);
          if (za < lo || za > hi || zb < lo || zb > hi) continue;
          const double xb = inverse_response[c][zb];
          if (!(xb > 0)) continue;
          ratios.push_back(inverse_response[c][za] / xb / expected);
        }
      }
    }
    // The median over pixels of the linearized ratio, against the exposure ratio.
    const double err = ratios.size() < 100 ? NAN : std::abs(Median(ratios) - 1.0);
    if (per_pair) per_pair->push_back(err);
    if (std::isfinite(err)) worst = std::isfinite(worst) ? std::max(worst, err) : err;
  }
  (void)bit_depth;
  return worst;
}

std::vector<std::vector<double>> DebevecInverseResponse(const std::vector<ExposureFrame>& frames,
                                                        const std::vector<double>& exposures_s) {
  std::vector<cv::Mat> images;
  std::vector<float> times;
  for (size_t j = 0; j < frames.size(); ++j) {
    cv::Mat im = frames[j].image;
    if (im.depth() != CV_8U) throw InputError("OpenCV's Debevec calibration takes 8-bit frames");
    if (im.channels() == 1) cv::cvtColor(im, im, cv::COLOR_GRAY2BGR);
    images.push_back(im);
    times.push_back(static_cast<float>(exposures_s[j]));
  }
  cv::Mat response;
  cv::createCalibrateDebevec()->process(images, response, times);
  const int channels = frames[0].image.channels();
  std::vector<std::vector<double>> out(channels, std::vector<double>(256));
  for (int z = 0; z < 256; ++z) {
    const cv::Vec3f v = response.at<cv::Vec3f>(z, 0);
    for (int c = 0; c < channels; ++c) out[c][z] = v[c];
  }
  return out;
}

}  // namespace gonio
