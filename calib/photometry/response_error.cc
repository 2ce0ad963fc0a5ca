// The inverse response's error model (calib/photometry/response.h ResponseErrorModel,
// docs/photometric.md "Error model").
//
// What errs in a fitted curve is mostly not where the self-check looks. A sweep whose exposures
// step by a factor r cannot tell h from h plus any function periodic in ln X with period ln r:
// every check between its frames compares values one step apart, where such a function takes
// the same value. Only the scene's own spread of radiances (pixels between the steps) pins those
// functions, and pixel noise on a few pinned values moves them (a noisy value is more likely
// to come from the side where the scene has more radiances, so the fit regresses to those: an
// errors-in-variables bias, the same for any noise seed). A bootstrap over the pixels keeps the
// scene's radiances and so its bias; frames left out change the step. So the sweep is simulated
// instead (a parametric bootstrap): its own sampled pixels at their fitted ln E, its frames at
// their times, values from the fitted curve with the pixel noise the fit's residuals show,
// rounded and clipped as the camera does; each simulated sweep is refitted exactly as the real
// one, and its curve compared with the curve it was simulated from. Their differences are
// draws of the fit's error, bias included, on this sweep's scene and steps.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

#include <fmt/format.h>

#include "calib/photometry/response_fit.h"
#include "common/error.h"
#include "common/parallel.h"
#include "common/stats.h"

namespace gonio {
namespace {

// The fitted curve as a map from ln X to a (continuous) pixel value: h on the knots, made
// strictly increasing, inverted by linear interpolation.
class ForwardResponse {
 public:
  ForwardResponse(const std::vector<double>& h, const Setup& s)
      : h_(h), spacing_(static_cast<double>(s.max_value) / (s.num_knots - 1)), max_(s.max_value) {
    for (size_t k = 1; k < h_.size(); ++k) h_[k] = std::max(h_[k], h_[k - 1] + 1e-9);
  }
  double Value(double ln_x) const {
    if (ln_x <= h_.front()) return 0.0;
    if (ln_x >= h_.back()) return max_;
    const size_t k = std::upper_bound(h_.begin(), h_.end(), ln_x) - h_.begin() - 1;
    return (k + (ln_x - h_[k]) / (h_[k + 1] - h_[k])) * spacing_;
  }

 private:
  std::vector<double> h_;
  double spacing_, max_;
};

constexpr int kNoiseBands = 32;
constexpr int kModelBands = 64;

// Per band of value (kNoiseBands over the range), the standard deviation of a pixel's value
// about the curve, from the fit's residuals r_i = h(Z_i) - ln E_p - ln t_j. A residual is the
// observation's noise less the noise of ln E_p, which the fit takes from all of the pixel's
// observations with weights omega = w^2 rho' (the fit's final weights): in ln units
// E[r_i^2] = (1 - 2 omega_i / W_p) s_i^2 + sum_j omega_j^2 s_j^2 / W_p^2, s_i the value noise
// times the curve's slope h'. A gamma curve's slope falls with the value, so the dark
// observations' noise dominates ln E_p and the bright ones' residuals: taken alone they read
// 1.5x their noise at the top of the 12-bit range. Solved for the band noise by a few fixed-
// point steps, each band's the median over its observations (robust to misregistered edges;
// the median of a chi-square with one degree of freedom is 0.4549); bands with too few
// observations take their nearest neighbour's.
std::vector<double> ValueNoise(const std::vector<KnotObservation>& obs, const ChannelFit& fit,
                               const Setup& s) {
  const double spacing = static_cast<double>(s.max_value) / (s.num_knots - 1);
  const size_t n = obs.size();
  std::vector<double> r(n), omega(n), slope(n, 0.0), total(fit.ln_e.size(), 0.0);
  std::vector<int> band(n);
  for (size_t i = 0; i < n; ++i) {
    const KnotObservation& o = obs[i];
    r[i] = (1 - o.a) * fit.h[o.k] + o.a * fit.h[o.k + 1] - fit.ln_e[o.pixel] - fit.ln_t[o.frame];
    omega[i] = o.w * o.w * HuberWeight(o.w * r[i], kHuberScale);
    slope[i] = (fit.h[o.k + 1] - fit.h[o.k]) / spacing;
    total[o.pixel] += omega[i];
    band[i] =
        std::clamp(static_cast<int>((o.k + o.a) * spacing / (s.max_value + 1.0) * kNoiseBands), 0,
                   kNoiseBands - 1);
  }
  std::vector<double> sd(kNoiseBands, 1.0);
  for (int step = 0; step < 4; ++step) {
    // The noise of each pixel's ln E under the current band noise.
    std::vector<double> shared(fit.ln_e.size(), 0.0);
    for (size_t i = 0; i < n; ++i) {
      const double si = sd[band[i]] * slope[i];
      shared[obs[i].pixel] += omega[i] * omega[i] * si * si;
    }
    // Per band the observations' (r^2, a s'^2, c): r^2 / (a s'^2 sigma^2 + c) is chi-square with
    // one degree of freedom, whose median is 0.4549; sigma solved for by bisection in log.
    struct Term {
      double r2, a, c;
    };
    std::vector<std::vector<Term>> in_band(kNoiseBands);
    for (size_t i = 0; i < n; ++i) {
      const double W = total[obs[i].pixel];
      const double a = 1 - 2 * omega[i] / W;
      if (!(slope[i] > 0) || !(a > 0.05) || !(W > 0)) continue;
      in_band[band[i]].push_back(
          {r[i] * r[i], a * slope[i] * slope[i], shared[obs[i].pixel] / (W * W)});
    }
    std::vector<double> next(kNoiseBands, NAN);
    std::vector<double> ratio;
    for (int b = 0; b < kNoiseBands; ++b) {
      if (in_band[b].size() < 20) continue;
      double lo = std::log(1e-3), hi = std::log(1e4);
      for (int it = 0; it < 40; ++it) {
        const double mid = 0.5 * (lo + hi), var = std::exp(2 * mid);
        ratio.clear();
        for (const Term& t : in_band[b]) ratio.push_back(t.r2 / (t.a * var + t.c));
        (Median(ratio) > 0.4549 ? lo : hi) = mid;
      }
      next[b] = std::exp(0.5 * (lo + hi));
    }
    for (int pass = 0; pass < kNoiseBands; ++pass) {
      for (int b = 0; b < kNoiseBands; ++b) {
        if (std::isfinite(next[b])) continue;
        if (b > 0 && std::isfinite(next[b - 1])) next[b] = next[b - 1];
        if (b + 1 < kNoiseBands && std::isfinite(next[b + 1])) next[b] = next[b + 1];
      }
    }
    for (int b = 0; b < kNoiseBands; ++b) sd[b] = std::isfinite(next[b]) ? next[b] : 0.5;
  }
  return sd;
}

// One simulated sweep: every sampled pixel with a fitted ln E in every usable frame its mask
// allows, its value from the fitted curve plus Gaussian noise (less the quantisation the
// rounding adds), rounded and clipped to the range; kept where the real fit would keep it.
std::vector<KnotObservation> Simulate(const ChannelFit& fit, const std::vector<int>& observed,
                                      const std::vector<cv::Point>& pixels,
                                      const std::vector<ExposureFrame>& frames, const Setup& s,
                                      const ForwardResponse& forward,
                                      const std::vector<double>& noise, std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<KnotObservation> obs;
  for (int p : observed) {
    for (int j : s.usable) {
      if (!Usable(frames[j], pixels[p])) continue;
      const double z0 = forward.Value(fit.ln_e[p] + fit.ln_t[j]);
      const int b =
          std::clamp(static_cast<int>(z0 / (s.max_value + 1.0) * kNoiseBands), 0, kNoiseBands - 1);
      const double sd = std::sqrt(std::max(0.0, noise[b] * noise[b] - 1.0 / 12));
      const double z =
          std::clamp(std::round(z0 + sd * normal(*rng)), 0.0, static_cast<double>(s.max_value));
      const double w = HatWeight(s, z);
      if (w < 0.05) continue;
      const auto [k, a] = KnotsOf(s, z);
      obs.push_back({p, j, k, a, w});
    }
  }
  return obs;
}

// ln X's error at value z of knot-valued differences d (linear between knots).
double At(const std::vector<double>& d, const Setup& s, double z) {
  const auto [k, a] = KnotsOf(s, std::clamp(z, 0.0, static_cast<double>(s.max_value)));
  return (1 - a) * d[k] + a * d[k + 1];
}

// The model from the simulated errors (per replicate, at the knots): per band of [lo, hi] the
// RMS over replicates of the error with each replicate's mean over the bands removed (an
// exposure scale), then averaged over +-1 correlation length (the simulated errors are few and
// their zeros fall where the simulation puts them, not where the fit's do); the correlation
// length from the errors' slopes: a smooth random curve with Gaussian covariance of length l
// has E[e'^2] = E[e^2] / l^2.
ResponseErrorModel::Channel BandStatistics(const std::vector<std::vector<double>>& diffs,
                                           const Setup& s, double lo, double hi) {
  const int B = static_cast<int>(diffs.size());
  ResponseErrorModel::Channel m;
  for (int e = 0; e <= kModelBands; ++e) m.value_edges.push_back(lo + (hi - lo) * e / kModelBands);
  const double width = (hi - lo) / kModelBands;
  std::vector<double> ms(kModelBands, 0.0);
  double sum_sq = 0, sum_sq_slope = 0;
  for (int b = 0; b < B; ++b) {
    std::vector<double> err(kModelBands);
    double mean = 0;
    for (int e = 0; e < kModelBands; ++e) {
      err[e] = At(diffs[b], s, lo + (e + 0.5) * width);
      mean += err[e] / kModelBands;
    }
    for (int e = 0; e < kModelBands; ++e) {
      err[e] -= mean;
      ms[e] += err[e] * err[e] / B;
      sum_sq += err[e] * err[e];
      if (e > 0) sum_sq_slope += std::pow((err[e] - err[e - 1]) / width, 2);
    }
  }
  m.correlation_length = sum_sq_slope > 0
                             ? std::sqrt(sum_sq / kModelBands / (sum_sq_slope / (kModelBands - 1)))
                             : hi - lo;
  m.correlation_length = std::clamp(m.correlation_length, width, hi - lo);
  for (int e = 0; e < kModelBands; ++e) {
    double sum = 0, weight = 0;
    for (int f = 0; f < kModelBands; ++f) {
      const double d = (f - e) * width / m.correlation_length;
      if (std::abs(d) > 1) continue;
      sum += ms[f];
      weight += 1;
    }
    m.sd.push_back(std::sqrt(sum / weight));
  }
  return m;
}

}  // namespace

ResponseErrorModel::Channel ChannelErrorModel(
    const std::vector<ExposureFrame>& frames, const std::vector<bool>& free_time, const Setup& s,
    const std::vector<cv::Point>& pixels, const std::vector<cv::Mat>& planes, const ChannelFit& fit,
    const ChannelFit& stiff, double lo, double hi, const ResponseOptions& o, int channel) {
  const auto obs = CollectObservations(planes, frames, s, pixels);
  std::vector<int> observed;
  std::vector<bool> seen(pixels.size(), false);
  for (const auto& ob : obs) seen[ob.pixel] = true;
  for (size_t p = 0; p < pixels.size(); ++p) {
    if (seen[p]) observed.push_back(static_cast<int>(p));
  }
  // The curve simulated is the stiffer prior's (SmoothingSensitivity's refit): the fit's own
  // curve carries its bias, whose wiggles change where the simulated values fall and so the
  // bias the simulation finds (on the 12-bit whole-stop sweep: 0.66 % RMS against a true
  // 1.2 %; from the stiffer curve 1.20 %, from the renderer's own curve 1.48 %).
  const ForwardResponse forward(stiff.h, s);
  const std::vector<double> noise = ValueNoise(obs, fit, s);
  if (std::getenv("GONIO_DEBUG_NOISE"))
    for (int b = 0; b < kNoiseBands; ++b) std::fprintf(stderr, "NOISE %d %.2f\n", b, noise[b]);
  const int B = o.error_replicates;
  std::vector<std::vector<double>> diffs(B);
  ParallelFor(B, o.threads, [&](size_t b0, size_t b1) {
    for (size_t b = b0; b < b1; ++b) {
      std::mt19937_64 rng(1000003ull * (channel + 1) + b);
      const auto sim = Simulate(stiff, observed, pixels, frames, s, forward, noise, &rng);
      const ChannelFit refit =
          FitKnotObservations(sim, pixels.size(), frames, free_time, false, s, o, &stiff);
      diffs[b].resize(fit.h.size());
      for (size_t k = 0; k < fit.h.size(); ++k) diffs[b][k] = refit.h[k] - stiff.h[k];
    }
  });
  return BandStatistics(diffs, s, lo, hi);
}

double ResponseErrorModel::Sd(int channel, double value) const {
  const Channel& c = channels.at(channel);
  const size_t n = c.sd.size();
  if (n == 1) return c.sd[0];
  const double first = 0.5 * (c.value_edges[0] + c.value_edges[1]);
  const double width = c.value_edges[1] - c.value_edges[0];
  const double pos = std::clamp((value - first) / width, 0.0, n - 1.0);
  const size_t k = std::min(static_cast<size_t>(pos), n - 2);
  const double a = pos - k;
  return (1 - a) * c.sd[k] + a * c.sd[k + 1];
}

double ResponseErrorModel::RmsSd() const {
  double sum = 0;
  size_t n = 0;
  for (const auto& c : channels) {
    for (double v : c.sd) sum += v * v, ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

nlohmann::json ResponseErrorModel::ToJson() const {
  nlohmann::json ch = nlohmann::json::array();
  for (const auto& c : channels) {
    ch.push_back({{"value_edges", c.value_edges},
                  {"sd", c.sd},
                  {"correlation_length", c.correlation_length}});
  }
  return {{"method", method},
          {"replicates", replicates},
          {"stiffer_prior", stiffer_prior},
          {"unit", "ln X (relative exposure), common offset removed"},
          {"channels", ch}};
}

ResponseErrorModel ResponseErrorModel::FromJson(const nlohmann::json& j,
                                                const std::string& source) {
  const auto bad = [&](const std::string& what) {
    return InputError(fmt::format("{}: error_model: {}", source, what));
  };
  if (!j.is_object() || !j.contains("channels") || !j["channels"].is_array()) {
    throw bad("needs 'channels' (an array)");
  }
  ResponseErrorModel m;
  m.method = j.value("method", "");
  const auto number = [&](const nlohmann::json& v, const char* key) {
    if (!v.is_number() || !std::isfinite(v.get<double>())) {
      throw bad(fmt::format("'{}' must hold finite numbers", key));
    }
    return v.get<double>();
  };
  if (j.contains("replicates"))
    m.replicates = static_cast<int>(number(j["replicates"], "replicates"));
  if (j.contains("stiffer_prior")) m.stiffer_prior = number(j["stiffer_prior"], "stiffer_prior");
  for (const auto& c : j["channels"]) {
    if (!c.is_object() || !c.contains("value_edges") || !c.contains("sd") ||
        !c.contains("correlation_length") || !c["value_edges"].is_array() || !c["sd"].is_array()) {
      throw bad("each channel needs 'value_edges', 'sd' and 'correlation_length'");
    }
    Channel ch;
    for (const auto& v : c["value_edges"]) ch.value_edges.push_back(number(v, "value_edges"));
    for (const auto& v : c["sd"]) ch.sd.push_back(number(v, "sd"));
    ch.correlation_length = number(c["correlation_length"], "correlation_length");
    if (ch.sd.empty() || ch.value_edges.size() != ch.sd.size() + 1) {
      throw bad("'value_edges' must hold one more value than 'sd'");
    }
    for (size_t e = 1; e < ch.value_edges.size(); ++e) {
      if (!(ch.value_edges[e] > ch.value_edges[e - 1])) {
        throw bad("'value_edges' must increase");
      }
    }
    for (double v : ch.sd) {
      if (!(v >= 0 && v < 10)) throw bad("'sd' must be in [0, 10) (ln units)");
    }
    if (!(ch.correlation_length > 0)) throw bad("'correlation_length' must be > 0");
    m.channels.push_back(std::move(ch));
  }
  return m;
}

}  // namespace gonio
