#include "estimation/joint/calibration_error.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/stats.h"
#include "common/vignetting.h"
#include "estimation/joint/joint_fit_problem.h"
#include "estimation/joint/vignette_share.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

// v times `scale`, less its mean (a common scale is the lamp's intensity).
std::vector<double> Centred(std::vector<double> v, double scale = 1.0) {
  double mean = 0;
  for (double x : v) mean += x;
  mean /= std::max<size_t>(v.size(), 1);
  for (double& x : v) x = scale * (x - mean);
  return v;
}

// The vignetting's error modes (calibration_error.h): r^2, r^4, x and y in half-diagonals
// about the principal point.
constexpr int kVignetteModes = 4;
double VignetteMode(const CalibrationErrorModel& e, int mode, const Eigen::Vector2d& pixel) {
  const Eigen::Vector2d d = (pixel - e.principal_point) / e.RadiusPx();
  switch (mode) {
    case 0:
      return d.squaredNorm();
    case 1:
      return d.squaredNorm() * d.squaredNorm();
    case 2:
      return d.x();
    default:
      return d.y();
  }
}

// Vignetting mode `mode` at the pixels `at`, centred over them (a common scale is the lamp's
// intensity) and scaled so that the mode, centred over the image, has an RMS of 1 there: V's
// accuracy is an RMS over the image (calib/photometry/vignette_accuracy.cc), and a sample seen
// in part of it meets only that part's share of a smooth error field. Scaled over the
// observations instead, a tilt across a sample that spans a third of the image would be drawn
// three times as steep as V's error allows. Empty when the mode does not vary at `at`.
std::vector<double> VignetteModeAt(const CalibrationErrorModel& e, int mode,
                                   const std::vector<Eigen::Vector2d>& at) {
  constexpr int kGrid = 64;  // image samples per axis for the image's RMS
  std::vector<double> image;
  for (int j = 0; j < kGrid; ++j) {
    for (int i = 0; i < kGrid; ++i) {
      const Eigen::Vector2d p((i + 0.5) / kGrid * e.image_size.x(),
                              (j + 0.5) / kGrid * e.image_size.y());
      image.push_back(VignetteMode(e, mode, p));
    }
  }
  double ss = 0;
  for (double x : Centred(std::move(image))) ss += x * x;
  const double image_rms = std::sqrt(ss / (kGrid * kGrid));
  std::vector<double> v;
  for (const auto& p : at) v.push_back(VignetteMode(e, mode, p));
  v = Centred(std::move(v), 1.0 / image_rms);
  double varies = 0;
  for (double x : v) varies = std::max(varies, std::abs(x));
  return image_rms > 1e-12 && varies > 1e-12 ? v : std::vector<double>{};
}

// Where the observations in `use` are read on the response: their raw values per channel, and
// V's input (the raw values V was measured from, channels averaged, with log2 of the inverse
// response there) with V's share of a field over it (vignette_share.h).
struct RawValues {
  std::vector<std::vector<double>> observed;
  VignetteShare vignette;
};

RawValues RawValuesAt(const ObservationSet& data, const std::vector<size_t>& use,
                      const CalibrationErrorModel& e) {
  RawValues r;
  std::vector<Eigen::Vector2d> px;
  for (size_t i : use) {
    const Observation& o = data.observations[i];
    r.observed.push_back(o.value);
    px.emplace_back(o.px, o.py);
  }
  r.vignette = VignetteShare(e.vignette_input_raw, e.vignette_input_log2x, e.vignette_input_cell_px,
                             e.vignette_kernel, e.vignette_kernel_log2x, e.principal_point,
                             e.RadiusPx(), px);
  return r;
}

struct ErrorModes {
  RawValues raw;
  std::vector<std::vector<double>> response, vignette;  // [mode][observation in `use`]
  std::vector<std::vector<double>> ends;                // in relative error per unit normal draw
  std::vector<double> truncation;  // a radial V's truncation (1 sigma), or empty
};

// A radial V's truncation (photometric.h VignetteResponseKernel::truncation) at the pixels `at`:
// the observation divided by 1 + dV / V, r held at the covered radius beyond it (the fit with
// the next term is meant there only), centred (a common scale is the lamp's intensity); empty
// without one.
std::vector<double> TruncationModeAt(const CalibrationErrorModel& e,
                                     const std::vector<Eigen::Vector2d>& at) {
  const VignetteResponseKernel& k = e.vignette_kernel;
  if (k.empty() || !(k.covered_radius > 0) ||
      std::all_of(k.truncation.begin(), k.truncation.end(), [](double t) { return t == 0; })) {
    return {};
  }
  std::vector<double> mode;
  for (const Eigen::Vector2d& p : at) {
    const double r2 = std::min((p - e.principal_point).squaredNorm() / std::pow(e.RadiusPx(), 2),
                               k.covered_radius * k.covered_radius);
    const double dv = RadialVignettingAtR2(k.truncation, r2) - 1.0;
    mode.push_back(-std::log1p(dv / RadialVignettingAtR2(k.v, r2)));
  }
  return Centred(std::move(mode));
}

// One response end's mode (calibration_error.h): the end's error times its weight at each
// observation's raw value in its channel, less V's share of it (vignette_share.h), centred (a
// common scale is the lamp's intensity); empty when no observation reaches the end.
std::vector<double> EndMode(const RawValues& raw, const ResponseEnd& end) {
  std::vector<double> m;
  bool reached = false;
  const auto weight = [&](double z) { return std::isfinite(z) ? end.WeightAt(z) : 0.0; };
  const std::vector<double> w_vignette = raw.vignette.At([&](double z, double) {
    const double w = weight(z);
    reached = reached || w > 0;
    return w;
  });
  for (size_t k = 0; k < raw.observed.size(); ++k) {
    const auto& value = raw.observed[k];
    const double w =
        weight(end.channel < static_cast<int>(value.size()) ? value[end.channel] : NAN);
    reached = reached || w > 0;
    m.push_back(end.error * (w - w_vignette[k]));
  }
  return reached ? Centred(std::move(m)) : std::vector<double>{};
}

// The response's slope and its change per octave (calibration_error.h) at the observations: in
// octaves u of the observed radiance about its median, less the same at V's input (in octaves
// of its linear value about their median), where known.
void AddSlopeModes(const ObservationSet& data, const std::vector<size_t>& use, ErrorModes* m) {
  std::vector<double> log_l, log_v;
  for (size_t i : use) {
    const auto& r = data.observations[i].radiance;
    double sum = 0;
    for (double x : r) sum += x;
    log_l.push_back(std::log2(std::max(sum / std::max<size_t>(r.size(), 1), 1e-300)));
  }
  for (double x : m->raw.vignette.ObservedLog2x()) {
    if (std::isfinite(x)) log_v.push_back(x);
  }
  const double median = Median(log_l), median_v = log_v.empty() ? 0.0 : Median(log_v);
  const std::vector<double> uv = m->raw.vignette.At([&](double, double x) { return x - median_v; });
  const std::vector<double> uv2 =
      m->raw.vignette.At([&](double, double x) { return (x - median_v) * (x - median_v); });
  std::vector<double> u, u2;
  for (size_t k = 0; k < use.size(); ++k) {
    u.push_back(log_l[k] - median - uv[k]);
    u2.push_back((log_l[k] - median) * (log_l[k] - median) - uv2[k]);
  }
  // In octaves, not normalised: the slope error is drawn per octave (calibration_error.h).
  m->response.push_back(Centred(u));
  m->response.push_back(Centred(u2, 0.5));
}

// The modes of calibration_error.h at the observations in `use`.
ErrorModes ModesAt(const ObservationSet& data, const std::vector<size_t>& use,
                   const CalibrationErrorModel& e) {
  ErrorModes m;
  m.raw = RawValuesAt(data, use, e);
  AddSlopeModes(data, use, &m);
  std::vector<Eigen::Vector2d> at;
  for (size_t i : use) at.emplace_back(data.observations[i].px, data.observations[i].py);
  for (int mode = 0; mode < kVignetteModes; ++mode) {
    auto n = VignetteModeAt(e, mode, at);
    if (!n.empty()) m.vignette.push_back(std::move(n));
  }
  for (const ResponseEnd& end : e.response_ends) {
    auto n = EndMode(m.raw, end);
    if (!n.empty()) m.ends.push_back(std::move(n));
  }
  m.truncation = TruncationModeAt(e, at);
  return m;
}

// A field over raw values, `scale` times it added to `log_field`: `value_at(channel, z)` at each
// observation's raw value in each of the first `channels`, the mean over channels, less V's
// share of the same mean (vignette_share.h): V divides the observation and was read through the
// same response.
template <typename ValueAt>
void AddRawField(const RawValues& raw, size_t channels, double scale, ValueAt value_at,
                 std::vector<double>* log_field) {
  const size_t used = raw.observed.empty() ? 0 : std::min(raw.observed[0].size(), channels);
  const std::vector<double> vignette = raw.vignette.At([&](double z, double) {
    double sum = 0;
    for (size_t c = 0; c < used; ++c) sum += value_at(c, z);
    return used > 0 ? sum / used : 0.0;
  });
  for (size_t k = 0; k < raw.observed.size(); ++k) {
    const auto& value = raw.observed[k];
    double sum = 0;
    int n = 0;
    for (size_t c = 0; c < std::min(value.size(), channels); ++c) {
      if (!std::isfinite(value[c])) continue;
      sum += value_at(c, value[c]);
      ++n;
    }
    if (n > 0) (*log_field)[k] += scale * (sum / n - vignette[k]);
  }
}

// AddRawField of a field over the response's knots: per channel linear between the knots
// (`knot_at(channel, k)`, k = 0, 1, ... every `spacing` raw values).
template <typename KnotAt>
void AddKnotField(const RawValues& raw, double spacing, size_t channels, double scale,
                  KnotAt knot_at, std::vector<double>* log_field) {
  const auto at = [&](size_t c, double z) {
    const double pos = std::max(z, 0.0) / spacing;
    const long j = static_cast<long>(pos);
    const double a = pos - j;
    return (1 - a) * knot_at(c, j) + a * knot_at(c, j + 1);
  };
  AddRawField(raw, channels, scale, at, log_field);
}

// One draw of the response's wiggles (calibration_error.h) at the observations in `modes`,
// added to `log_field`: a normal draw per channel and knot.
void AddWiggles(const ErrorModes& modes, const CalibrationErrorModel& e, std::mt19937_64* rng,
                std::vector<double>* log_field) {
  if (!(e.response_wiggle > 0) || !(e.response_knot_spacing > 0)) return;
  std::normal_distribution<double> normal(0.0, 1.0);
  std::map<std::pair<size_t, long>, double> knot;  // (channel, knot) -> draw, made when reached
  const auto at = [&](size_t c, long k) {
    auto it = knot.find({c, k});
    if (it == knot.end()) it = knot.emplace(std::make_pair(c, k), normal(*rng)).first;
    return it->second;
  };
  AddKnotField(modes.raw, e.response_knot_spacing, SIZE_MAX, e.response_wiggle, at, log_field);
}

// log2 of the inverse response at raw value z in channel c (the last table for channels beyond
// it), interpolated; floored at a millionth of the table's top (it is 0 at and below black).
double Log2Linear(const std::vector<std::vector<double>>& inverse, size_t c, double z) {
  const auto& t = inverse[std::min(c, inverse.size() - 1)];
  return std::log2(std::max(LinearizeTable(t, z), 1e-6 * t.back()));
}

// One draw of the response's prior-held part (calibration_error.h) at the observations in
// `modes`, added to `log_field`: one periodic function of log2 X(z) for every channel
// (the bands' figure is the largest over them), scaled by the band figure at z, less the same at
// the raw value V was measured from.
void AddPriorPart(const ErrorModes& modes, const CalibrationErrorModel& e, std::mt19937_64* rng,
                  std::vector<double>* log_field) {
  const auto& bands = e.response_prior_bands;
  if (bands.empty() || !(e.response_band_width > 0) || !(e.response_prior_period_octaves > 0)) {
    return;
  }
  // One harmonic: in log2 X the true error of the coverage bench's 40 user responses is a
  // sine of the sweep's step (its RMS over the middle of the range 0.106 % on third stops and
  // 1.77 % on whole stops against 0.019 % and 0.30 % for the second harmonic, docs/pipeline.md
  // "Calibration error"). Two, each with half the variance, averaged out over a sample's values
  // and under-drew its effect.
  constexpr int kHarmonics = 1;
  std::normal_distribution<double> normal(0.0, 1.0);
  double a[kHarmonics], b[kHarmonics];
  for (int h = 0; h < kHarmonics; ++h) a[h] = normal(*rng), b[h] = normal(*rng);
  const auto field = [&](size_t c, double z) {
    const long band =
        static_cast<long>(std::floor((z - e.response_band_lo) / e.response_band_width));
    const double s = bands[std::clamp<long>(band, 0, static_cast<long>(bands.size()) - 1)];
    const double phase =
        2 * kPi * Log2Linear(e.response_prior_inverse, c, z) / e.response_prior_period_octaves;
    double sum = 0;
    for (int h = 0; h < kHarmonics; ++h) {
      sum += a[h] * std::sin((h + 1) * phase) + b[h] * std::cos((h + 1) * phase);
    }
    return s * sum / std::sqrt(static_cast<double>(kHarmonics));
  };
  AddRawField(modes.raw, SIZE_MAX, 1.0, field, log_field);
}

// Draw `draw` of the response's statistical error (calibration_error.h): its bootstrap refit
// `draw` (cycled) with a random sign, at the observations in `modes`, added to `log_field`;
// beyond the last knot its value there.
void AddReplicate(const ErrorModes& modes, const CalibrationErrorModel& e, int draw,
                  std::mt19937_64* rng, std::vector<double>* log_field) {
  if (e.response_replicates.empty() || !(e.response_knot_spacing > 0)) return;
  const auto& refit = e.response_replicates[draw % e.response_replicates.size()];
  const double sign = std::bernoulli_distribution(0.5)(*rng) ? 1.0 : -1.0;
  const auto at = [&](size_t c, long k) {
    const auto& d = refit[c];
    return d[std::min(static_cast<size_t>(k), d.size() - 1)];
  };
  AddKnotField(modes.raw, e.response_knot_spacing, refit.size(), sign, at, log_field);
}

// The observations in `use`, every radiance (and its variance) multiplied by draw `draw` of the
// calibration error field, and every frame's observations moved by a draw of its pose error.
ObservationSet PerturbedCopy(const ObservationSet& data, const std::vector<size_t>& use,
                             const ErrorModes& modes, const CalibrationErrorModel& e, int draw,
                             std::mt19937_64* rng, std::mt19937_64* pose_rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> log_field(use.size(), 0.0);
  // Response modes are in octaves of radiance: a slope error a per octave is a ratio error of
  // 2^a - 1 ~ a ln 2 per octave, so ln-amplitude = ratio error (to first order).
  const auto add = [&](const std::vector<std::vector<double>>& ms, double sd) {
    for (const auto& m : ms) {
      const double a = sd * normal(*rng);
      for (size_t k = 0; k < use.size(); ++k) log_field[k] += a * m[k];
    }
  };
  add(modes.response, e.response_ratio_error);
  add(modes.ends, 1.0);
  if (!modes.truncation.empty()) add({modes.truncation}, 1.0);
  AddWiggles(modes, e, rng, &log_field);
  AddPriorPart(modes, e, rng, &log_field);
  AddReplicate(modes, e, draw, rng, &log_field);
  add(modes.vignette, e.vignette_rms / std::sqrt(std::max<size_t>(modes.vignette.size(), 1)));
  const std::vector<PoseDelta> pose_error = DrawPoseErrors(e.poses, pose_rng);
  ObservationSet out;
  out.channels = data.channels;
  out.frame_files = data.frame_files;
  out.observations.reserve(use.size());
  for (size_t k = 0; k < use.size(); ++k) {
    Observation o = data.observations[use[k]];
    if (o.frame >= 0 && static_cast<size_t>(o.frame) < pose_error.size()) {
      MoveObservationPose(pose_error[o.frame], &o);
    }
    const double f = std::exp(log_field[k]);
    for (double& x : o.radiance) x *= f;
    for (double& v : o.variance) v *= f * f;
    out.observations.push_back(std::move(o));
  }
  return out;
}

// A refit's nuisance terms appended per channel (as many as the fit's; a refit always holds
// the fit's terms: same options).
void CollectNuisances(const JointFitResult& r, std::vector<std::vector<double>>* ambient_sample,
                      std::vector<std::vector<double>>* ambient_irradiance,
                      std::vector<double>* height) {
  for (size_t c = 0; c < ambient_sample->size() && c < r.ambient_sample.size(); ++c) {
    (*ambient_sample)[c].push_back(r.ambient_sample[c]);
  }
  for (size_t c = 0; c < ambient_irradiance->size() && c < r.ambient_irradiance.size(); ++c) {
    (*ambient_irradiance)[c].push_back(r.ambient_irradiance[c]);
  }
  if (r.sample_height_offset) height->push_back(*r.sample_height_offset);
}

// The refits' spread; 0 (nothing added) with fewer than two refits.
double StdDev(const std::vector<double>& v) { return v.size() < 2 ? 0.0 : SampleStddev(v); }

}  // namespace

void CalibrationErrorModel::Check() const {
  if (!(response_ratio_error >= 0 && response_ratio_error < 1)) {
    throw InputError("calibration error: response_ratio_error must be in [0, 1)");
  }
  if (!(vignette_rms >= 0 && vignette_rms < 1)) {
    throw InputError("calibration error: vignette_rms must be in [0, 1)");
  }
  if (!(response_wiggle >= 0 && response_wiggle < 1) || !(response_knot_spacing >= 0)) {
    throw InputError("calibration error: response_wiggle must be in [0, 1), its spacing >= 0");
  }
  for (double b : response_prior_bands) {
    if (!(b >= 0 && b < 1)) {
      throw InputError("calibration error: a response prior band's error must be in [0, 1)");
    }
  }
  if (!response_prior_bands.empty() &&
      !(response_band_width > 0 && std::isfinite(response_band_lo) &&
        response_prior_period_octaves > 0 && !response_prior_inverse.empty())) {
    throw InputError(
        "calibration error: the response's prior part needs bands of width > 0, a period > 0 "
        "and the inverse response");
  }
  for (const auto& t : response_prior_inverse) {
    if (t.size() < 2 || !(t.back() > 0)) {
      throw InputError("calibration error: an inverse response table needs 2 values, the last > 0");
    }
  }
  for (const auto& refit : response_replicates) {
    for (const auto& d : refit) {
      if (d.size() < 2 ||
          !std::all_of(d.begin(), d.end(), [](double v) { return std::isfinite(v); })) {
        throw InputError("calibration error: a response replicate needs finite values at 2+ knots");
      }
    }
  }
  for (const auto& end : response_ends) {
    if (!(end.error >= 0 && end.error < 1) || !std::isfinite(end.end) ||
        !std::isfinite(end.taper_to)) {
      throw InputError("calibration error: a response end's error must be in [0, 1)");
    }
  }
  poses.Check();
  if (!principal_point.allFinite()) {
    throw InputError("calibration error: the principal point must be finite");
  }
  if (!(image_size.minCoeff() > 0) || !image_size.allFinite()) {
    throw InputError("calibration error: the image size must be finite, > 0");
  }
  if (!vignette_input_raw.empty() &&
      (vignette_input_cell_px < 1 || vignette_input_raw.type() != CV_32F ||
       vignette_input_log2x.size() != vignette_input_raw.size() ||
       vignette_input_log2x.type() != CV_32F)) {
    throw InputError(
        "calibration error: V's input raw values need their log2 X of the same size (CV_32F) and "
        "a cell of at least 1 px");
  }
  if (vignette_kernel.weight.size() != vignette_kernel.raw.size() ||
      vignette_kernel_log2x.size() != vignette_kernel.raw.size()) {
    throw InputError("calibration error: V's response kernel needs a weight and log2 X per value");
  }
}

void CalibrationPropagationOptions::Check() const {
  if (draws < 2 || draws > 1000) throw InputError("calibration draws must be in [2, 1000]");
  if (max_observations < 10) throw InputError("calibration max_observations must be >= 10");
}

CalibrationPropagation PropagateCalibrationError(const ObservationSet& data,
                                                 const JointFitResult& fit,
                                                 const JointFitOptions& fit_options,
                                                 const CalibrationErrorModel& error,
                                                 const CalibrationPropagationOptions& options) {
  error.Check();
  options.Check();
  const std::vector<size_t> use = joint_fit_internal::Subsample(data, options.max_observations);
  const ErrorModes modes = ModesAt(data, use, error);
  std::vector<size_t> all(use.size());
  for (size_t k = 0; k < all.size(); ++k) all[k] = k;
  // The poses' draws from a stream of their own: the photometric draws stay what they are
  // without them.
  std::mt19937_64 rng(options.seed), pose_rng(options.seed + 0x9E3779B97F4A7C15ull);
  const size_t np = fit.material.params.size();
  // The refits model each patch as the fit did (its kAuto decided once).
  JointFitOptions refit_options = fit_options;
  refit_options.patch_model = fit.patch_model;
  std::vector<std::vector<double>> params(np);
  std::vector<double> lx, ly, lz, intensity, height;
  std::vector<std::vector<double>> ambient_sample(fit.ambient_sample.size()),
      ambient_irradiance(fit.ambient_irradiance.size());
  for (int d = 0; d < options.draws; ++d) {
    const ObservationSet perturbed = PerturbedCopy(data, use, modes, error, d, &rng, &pose_rng);
    const JointFitResult r = joint_fit_internal::FitCandidate(
        fit.material.model, perturbed, all, fit.lamp_position, refit_options, false);
    if (!r.material.converged || r.material.params.size() != np) continue;
    for (size_t i = 0; i < np; ++i) params[i].push_back(r.material.params[i]);
    lx.push_back(r.lamp_position.x());
    ly.push_back(r.lamp_position.y());
    lz.push_back(r.lamp_position.z());
    intensity.push_back(r.intensity);
    CollectNuisances(r, &ambient_sample, &ambient_irradiance, &height);
  }
  CalibrationPropagation p;
  p.draws = static_cast<int>(lx.size());
  p.photometric = error.photometric;
  p.poses = !error.poses.empty();
  if (2 * p.draws < options.draws) {
    throw NumericalError(fmt::format(
        "calibration error propagation: only {} of {} refits converged", p.draws, options.draws));
  }
  p.param_names = fit.material.param_names;
  for (size_t i = 0; i < np; ++i) p.param_stddev.push_back(StdDev(params[i]));
  p.lamp_stddev = Eigen::Vector3d(StdDev(lx), StdDev(ly), StdDev(lz));
  p.intensity_stddev = StdDev(intensity);
  for (const auto& v : ambient_sample) p.ambient_sample_stddev.push_back(StdDev(v));
  for (const auto& v : ambient_irradiance) p.ambient_irradiance_stddev.push_back(StdDev(v));
  if (fit.sample_height_offset) p.sample_height_stddev = StdDev(height);
  spdlog::debug("calibration error propagated over {} refits", p.draws);
  return p;
}

std::optional<CalibrationErrorModel> CalibrationErrorModelAt(
    const PhotometricCalibration& photometric, const ObservationSet& data,
    const CameraModel& camera, const PoseErrorModel& poses) {
  const auto& accuracy = photometric.relative_accuracy;
  if (!accuracy && poses.empty()) return std::nullopt;
  CalibrationErrorModel e;
  e.principal_point = {camera.intrinsics[2], camera.intrinsics[3]};
  e.image_size = {static_cast<double>(camera.width), static_cast<double>(camera.height)};
  e.poses = poses;
  e.photometric = accuracy.has_value();
  if (!accuracy) return e;  // the poses' error alone, the photometric fields zero
  const ResponseResult& response = photometric.response;
  // The response's error where the observations are: their raw values' bands.
  e.response_ratio_error =
      PhotometricCalibration::ResponseSlopeErrorAt(response, RawValuesOf(data));
  // Where the sweep's data thin out, the table's own error (response.h, ResponseEnd).
  e.response_ends = response.ends;
  // Its wiggles between knots: the smoothing sensitivity is the change under a prior
  // kSmoothingSensitivityFactor times stiffer, (factor - 1) times the prior's bias where the
  // data hold the curve (the bias grows in proportion to the prior's weight there).
  // With the table's bootstrap refits, their draws instead: they measure its error between the
  // sweep's values, where the smoothing sensitivity's worst band only bounds it.
  if (std::isfinite(response.knot_spacing)) {
    e.response_knot_spacing = response.knot_spacing;
    e.response_replicates = response.bootstrap_ln_change;
    if (e.response_replicates.empty()) {
      e.response_wiggle =
          PhotometricCalibration::SmoothingError(response) / (kSmoothingSensitivityFactor - 1.0);
    }
  }
  // Its part the sweep leaves to the prior, which the bootstrap reproduces (a band without a
  // figure counts as the worst, as in PhotometricCalibration::SmoothingSensitivityAt).
  const auto& bands = response.smoothing_sensitivity_bands;
  const auto& c = response.consistency;
  if (!bands.empty() && c.range_hi > c.range_lo) {
    for (double b : bands) {
      e.response_prior_bands.push_back(
          std::min(std::isfinite(b) ? b : PhotometricCalibration::SmoothingError(response), 0.99));
    }
    e.response_band_lo = c.range_lo;
    e.response_band_width = (c.range_hi - c.range_lo) / bands.size();
    e.response_prior_inverse = response.inverse_response;
    e.response_prior_period_octaves = ExposurePeriodOctaves(response);
  }
  // The rest of relative_accuracy is the vignetting's: less the response's worst band (its part
  // of relative_accuracy) and its wiggles between the sweep's values (SmoothingError), which
  // are in the noise floor but are no smooth field.
  const double worst = std::min(PhotometricCalibration::ResponseAccuracy(response), *accuracy);
  const double smoothing = PhotometricCalibration::SmoothingError(response);
  e.vignette_rms =
      std::sqrt(std::max(0.0, *accuracy * *accuracy - worst * worst - smoothing * smoothing));
  SetVignetteInput(photometric, &e);
  return e;
}

}  // namespace gonio
