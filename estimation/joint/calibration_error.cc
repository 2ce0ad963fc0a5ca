#include "estimation/joint/calibration_error.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/stats.h"
#include "estimation/joint/joint_fit_problem.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

// v centred and scaled to an RMS of 1; empty when v does not vary (the mode is a pure scale,
// which the lamp intensity absorbs).
std::vector<double> Normalised(std::vector<double> v) {
  double mean = 0;
  for (double x : v) mean += x;
  mean /= std::max<size_t>(v.size(), 1);
  double ss = 0;
  for (double& x : v) {
    x -= mean;
    ss += x * x;
  }
  const double rms = std::sqrt(ss / std::max<size_t>(v.size(), 1));
  if (!(rms > 1e-12)) return {};
  for (double& x : v) x /= rms;
  return v;
}

// The vignetting modes of calibration_error.h at the observations in `use`.
std::vector<std::vector<double>> VignetteModes(const ObservationSet& data,
                                               const std::vector<size_t>& use,
                                               const CalibrationErrorModel& e) {
  std::vector<double> r2, r4, tx, ty;
  for (size_t i : use) {
    const Observation& o = data.observations[i];
    const double dx = (o.px - e.principal_point.x()) / e.radius_px;
    const double dy = (o.py - e.principal_point.y()) / e.radius_px;
    const double rr = dx * dx + dy * dy;
    r2.push_back(rr);
    r4.push_back(rr * rr);
    tx.push_back(dx);
    ty.push_back(dy);
  }
  std::vector<std::vector<double>> modes;
  for (auto* v : {&r2, &r4, &tx, &ty}) {
    auto n = Normalised(*v);
    if (!n.empty()) modes.push_back(std::move(n));
  }
  return modes;
}

// Draws of one channel's response error curve: a Gaussian process over the band centres with
// covariance sd_a sd_b exp(-(z_a - z_b)^2 / (2 l^2)), its square root taken through the
// eigen-decomposition (a Gaussian kernel's matrix is numerically semi-definite).
class ResponseCurveSampler {
 public:
  explicit ResponseCurveSampler(const ResponseErrorModel::Channel& c) {
    const int n = static_cast<int>(c.sd.size());
    Eigen::MatrixXd cov(n, n);
    for (int a = 0; a < n; ++a) {
      centre_.push_back(0.5 * (c.value_edges[a] + c.value_edges[a + 1]));
    }
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) {
        const double d = (centre_[a] - centre_[b]) / c.correlation_length;
        cov(a, b) = c.sd[a] * c.sd[b] * std::exp(-0.5 * d * d);
      }
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(cov);
    root_ = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  }
  // One curve at the band centres.
  std::vector<double> Draw(std::mt19937_64* rng) const {
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::VectorXd xi(root_.cols());
    for (int k = 0; k < xi.size(); ++k) xi(k) = normal(*rng);
    const Eigen::VectorXd e = root_ * xi;
    return std::vector<double>(e.data(), e.data() + e.size());
  }
  // A curve's value at pixel value z: linear between band centres, the end bands' beyond.
  double At(const std::vector<double>& curve, double z) const {
    if (z <= centre_.front()) return curve.front();
    if (z >= centre_.back()) return curve.back();
    const size_t k = std::upper_bound(centre_.begin(), centre_.end(), z) - centre_.begin() - 1;
    const double a = (z - centre_[k]) / (centre_[k + 1] - centre_[k]);
    return (1 - a) * curve[k] + a * curve[k + 1];
  }

 private:
  std::vector<double> centre_;
  Eigen::MatrixXd root_;
};

// ln of the response error field at each observation in `use`: one curve per channel, at the
// observation's pixel value (0 where the observation has none).
std::vector<std::vector<double>> ResponseField(const ObservationSet& data,
                                               const std::vector<size_t>& use,
                                               const std::vector<ResponseCurveSampler>& samplers,
                                               std::mt19937_64* rng) {
  std::vector<std::vector<double>> curves;
  for (const auto& s : samplers) curves.push_back(s.Draw(rng));
  std::vector<std::vector<double>> field(use.size());
  for (size_t k = 0; k < use.size(); ++k) {
    const Observation& o = data.observations[use[k]];
    field[k].assign(o.radiance.size(), 0.0);
    if (o.value.size() != o.radiance.size()) continue;
    for (size_t c = 0; c < o.radiance.size() && c < samplers.size(); ++c) {
      field[k][c] = samplers[c].At(curves[c], o.value[c]);
    }
  }
  return field;
}

// ln of one vignetting field at each observation in `use` (the same for every channel).
std::vector<double> VignetteField(const std::vector<std::vector<double>>& modes, double rms,
                                  size_t n, std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> field(n, 0.0);
  const double sd = rms / std::sqrt(std::max<size_t>(modes.size(), 1));
  for (const auto& m : modes) {
    const double a = sd * normal(*rng);
    for (size_t k = 0; k < n; ++k) field[k] += a * m[k];
  }
  return field;
}

// The observations in `use`, every radiance (and its variance) multiplied by exp(field).
ObservationSet PerturbedCopy(const ObservationSet& data, const std::vector<size_t>& use,
                             const std::vector<std::vector<double>>& field) {
  ObservationSet out;
  out.channels = data.channels;
  out.frame_files = data.frame_files;
  out.observations.reserve(use.size());
  for (size_t k = 0; k < use.size(); ++k) {
    Observation o = data.observations[use[k]];
    for (size_t c = 0; c < o.radiance.size(); ++c) {
      const double f = std::exp(field[k][c]);
      o.radiance[c] *= f;
      o.variance[c] *= f * f;
    }
    out.observations.push_back(std::move(o));
  }
  return out;
}

// The refits' spread; 0 (nothing added) with fewer than two refits.
double StdDev(const std::vector<double>& v) { return v.size() < 2 ? 0.0 : SampleStddev(v); }

// Refits of `fit` under `draws` fields from `field_of(draw)`; NumericalError when fewer than
// half converge.
template <typename FieldOf>
CalibrationSpread Refits(const ObservationSet& data, const std::vector<size_t>& use,
                         const JointFitResult& fit, const JointFitOptions& fit_options, int draws,
                         const char* source, FieldOf field_of) {
  std::vector<size_t> all(use.size());
  for (size_t k = 0; k < all.size(); ++k) all[k] = k;
  const size_t np = fit.material.params.size();
  std::vector<std::vector<double>> params(np);
  std::vector<double> lx, ly, lz, intensity;
  for (int d = 0; d < draws; ++d) {
    const ObservationSet perturbed = PerturbedCopy(data, use, field_of());
    const JointFitResult r = joint_fit_internal::FitCandidate(
        fit.material.model, perturbed, all, fit.light_position, fit_options, false);
    if (!r.material.converged || r.material.params.size() != np) continue;
    for (size_t i = 0; i < np; ++i) params[i].push_back(r.material.params[i]);
    lx.push_back(r.light_position.x());
    ly.push_back(r.light_position.y());
    lz.push_back(r.light_position.z());
    intensity.push_back(r.intensity);
  }
  CalibrationSpread s;
  s.draws = static_cast<int>(lx.size());
  if (2 * s.draws < draws) {
    throw NumericalError(
        fmt::format("calibration error propagation: only {} of {} refits under "
                    "the {} error converged",
                    s.draws, draws, source));
  }
  for (size_t i = 0; i < np; ++i) s.param_stddev.push_back(StdDev(params[i]));
  s.light_stddev = Eigen::Vector3d(StdDev(lx), StdDev(ly), StdDev(lz));
  s.intensity_stddev = StdDev(intensity);
  return s;
}

}  // namespace

void CalibrationErrorModel::Check() const {
  for (const auto& c : response.channels) {
    if (c.sd.empty() || c.value_edges.size() != c.sd.size() + 1 || !(c.correlation_length > 0)) {
      throw InputError("calibration error: a response error model needs bands and a length");
    }
    for (double v : c.sd) {
      if (!(v >= 0 && v < 10)) throw InputError("calibration error: response sd must be >= 0");
    }
  }
  if (!(vignette_rms >= 0 && vignette_rms < 1)) {
    throw InputError("calibration error: vignette_rms must be in [0, 1)");
  }
  if (!(radius_px > 0) || !principal_point.allFinite()) {
    throw InputError("calibration error: the principal point and radius must be finite, > 0");
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
  std::mt19937_64 rng(options.seed);
  CalibrationPropagation p;
  p.param_names = fit.material.param_names;
  std::vector<ResponseCurveSampler> samplers;
  for (const auto& c : error.response.channels) samplers.emplace_back(c);
  if (!samplers.empty()) {
    p.response = Refits(data, use, fit, fit_options, options.draws, "response",
                        [&] { return ResponseField(data, use, samplers, &rng); });
  }
  const auto modes = VignetteModes(data, use, error);
  if (error.vignette_rms > 0 && !modes.empty()) {
    p.vignetting = Refits(data, use, fit, fit_options, options.draws, "vignetting", [&] {
      const std::vector<double> v = VignetteField(modes, error.vignette_rms, use.size(), &rng);
      std::vector<std::vector<double>> field(use.size());
      for (size_t k = 0; k < use.size(); ++k) {
        field[k].assign(data.observations[use[k]].radiance.size(), v[k]);
      }
      return field;
    });
  }
  const size_t np = fit.material.params.size();
  auto& t = p.total;
  t.draws = p.response.draws + p.vignetting.draws;
  t.param_stddev.assign(np, 0.0);
  for (const CalibrationSpread* s : {&p.response, &p.vignetting}) {
    if (s->draws == 0) continue;
    for (size_t i = 0; i < np; ++i)
      t.param_stddev[i] = std::hypot(t.param_stddev[i], s->param_stddev[i]);
    for (int k = 0; k < 3; ++k)
      t.light_stddev[k] = std::hypot(t.light_stddev[k], s->light_stddev[k]);
    t.intensity_stddev = std::hypot(t.intensity_stddev, s->intensity_stddev);
  }
  spdlog::debug("calibration error propagated over {} refits", t.draws);
  return p;
}

double ResponseScatter(const ResponseErrorModel& model, const ObservationSet& data,
                       size_t max_observations) {
  if (model.empty() || data.observations.empty()) return 0.0;
  const std::vector<size_t> use = joint_fit_internal::Subsample(data, max_observations);
  double sum = 0;
  int channels = 0;
  for (size_t c = 0; c < model.channels.size(); ++c) {
    const auto& m = model.channels[c];
    std::vector<double> z, sd;
    for (size_t i : use) {
      const Observation& o = data.observations[i];
      if (o.value.size() <= c) continue;
      z.push_back(o.value[c]);
      sd.push_back(model.Sd(static_cast<int>(c), o.value[c]));
    }
    if (z.empty()) continue;
    double var = 0, cov = 0;
    for (size_t a = 0; a < z.size(); ++a) {
      var += sd[a] * sd[a];
      for (size_t b = 0; b < z.size(); ++b) {
        const double d = (z[a] - z[b]) / m.correlation_length;
        cov += sd[a] * sd[b] * std::exp(-0.5 * d * d);
      }
    }
    const double n = static_cast<double>(z.size());
    sum += std::max(0.0, var / n - cov / (n * n));
    ++channels;
  }
  return channels > 0 ? std::sqrt(sum / channels) : 0.0;
}

void AddCalibrationUncertainty(const CalibrationPropagation& p, JointFitResult* fit) {
  const CalibrationSpread& t = p.total;
  auto& sd = fit->material.stddev;
  for (size_t i = 0; i < std::min(sd.size(), t.param_stddev.size()); ++i) {
    if (sd[i]) sd[i] = std::hypot(*sd[i], t.param_stddev[i]);
  }
  if (fit->light_stddev) {
    for (int k = 0; k < 3; ++k) {
      (*fit->light_stddev)[k] = std::hypot((*fit->light_stddev)[k], t.light_stddev[k]);
    }
  }
  if (fit->intensity_stddev) {
    fit->intensity_stddev = std::hypot(*fit->intensity_stddev, t.intensity_stddev);
  }
}

nlohmann::json CalibrationSpread::ToJson(const std::vector<std::string>& names) const {
  nlohmann::json params = nlohmann::json::object();
  for (size_t i = 0; i < std::min(names.size(), param_stddev.size()); ++i) {
    params[names[i]] = param_stddev[i];
  }
  return {{"draws", draws},
          {"param_stddev", params},
          {"light_stddev", {light_stddev.x(), light_stddev.y(), light_stddev.z()}},
          {"intensity_stddev", intensity_stddev}};
}

std::string CalibrationPropagation::Report() const {
  std::string s;
  const auto line = [&](const char* what, const CalibrationSpread& c) {
    if (c.draws == 0) return;
    s += fmt::format("calibration error, {} ({} refits):", what, c.draws);
    for (size_t i = 0; i < param_names.size() && i < c.param_stddev.size(); ++i) {
      s += fmt::format(" {} +-{:.3g}", param_names[i], c.param_stddev[i]);
    }
    s +=
        fmt::format(", lamp +-({:.2g}, {:.2g}, {:.2g}) m, intensity +-{:.3g}\n", c.light_stddev.x(),
                    c.light_stddev.y(), c.light_stddev.z(), c.intensity_stddev);
  };
  line("response", response);
  line("vignetting", vignetting);
  return s;
}

nlohmann::json CalibrationPropagation::ToJson() const {
  nlohmann::json j = total.ToJson(param_names);
  j["response"] = response.draws > 0 ? response.ToJson(param_names) : nlohmann::json();
  j["vignetting"] = vignetting.draws > 0 ? vignetting.ToJson(param_names) : nlohmann::json();
  return j;
}

}  // namespace gonio
