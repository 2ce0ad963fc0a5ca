#include "estimation/joint_fit.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <set>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "common/parallel.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

// Lamp position in the board frame for one observation.
template <typename T>
void LightInBoard(const Observation& o, bool light_in_camera, const T* light, T* lb) {
  if (!light_in_camera) {
    for (int k = 0; k < 3; ++k) lb[k] = light[k];
    return;
  }
  const T aa[3] = {T(o.board_from_cam_aa.x()), T(o.board_from_cam_aa.y()),
                   T(o.board_from_cam_aa.z())};
  ceres::AngleAxisRotatePoint(aa, light, lb);
  for (int k = 0; k < 3; ++k) lb[k] += T(o.camera_in_board[k]);
}

// Irradiance factor cos(theta_i)/d^2 and the directions to lamp and camera in the sample frame
// (board x, -y, -z: the sample's outward normal is -z_board).
template <typename T>
T Geometry(const Observation& o, const T* lb, T* ls, T* vs) {
  const T l[3] = {lb[0] - T(o.p_in_board.x()), lb[1] - T(o.p_in_board.y()),
                  lb[2] - T(o.p_in_board.z())};
  ls[0] = l[0];
  ls[1] = -l[1];
  ls[2] = -l[2];
  const Eigen::Vector3d v = o.camera_in_board - o.p_in_board;
  vs[0] = T(v.x());
  vs[1] = T(-v.y());
  vs[2] = T(-v.z());
  const T d2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
  using std::sqrt;
  return ls[2] / (d2 * sqrt(d2));  // cos(theta_i) / d^2
}

template <typename M>
struct SampleRadianceResidual {
  const Observation* o;
  int channel;
  double inv_sigma;
  bool light_in_camera;
  std::array<bool, 16> is_scale;
  template <typename T>
  bool operator()(const T* shape, const T* chan, const T* light, const T* intensity, T* r) const {
    T lb[3], ls[3], vs[3];
    LightInBoard(*o, light_in_camera, light, lb);
    const T e = Geometry(*o, lb, ls, vs);
    T p[M::kNumParams];
    for (int k = 0; k < M::kNumParams; ++k) p[k] = is_scale[k] ? chan[k] : shape[k];
    T f = T(0);
    if (ls[2] > T(0)) f = M::Evaluate(p, AnglesFromDirections(ls, vs));
    const T model = e > T(0) ? f * intensity[0] * e : T(0);
    r[0] = (model - T(o->radiance[channel])) * T(inv_sigma);
    return true;
  }
};

struct WhiteRadianceResidual {
  const Observation* o;
  int channel;
  double inv_sigma, white_albedo;
  bool light_in_camera;
  template <typename T>
  bool operator()(const T* light, const T* intensity, T* r) const {
    T lb[3], ls[3], vs[3];
    LightInBoard(*o, light_in_camera, light, lb);
    const T e = Geometry(*o, lb, ls, vs);
    const T model = e > T(0) ? T(white_albedo * kInvPi) * intensity[0] * e : T(0);
    r[0] = (model - T(o->radiance[channel])) * T(inv_sigma);
    return true;
  }
};

double Sigma(const Observation& o, int c, double floor) {
  return std::sqrt(o.variance[c] + floor * floor * o.radiance[c] * o.radiance[c]) + 1e-30;
}

struct State {
  std::vector<double> shape;
  std::vector<std::vector<double>> chan;  // per channel, full parameter vectors
  Eigen::Vector3d light;
  double intensity = 1;
  double cost = INFINITY;
  bool usable = false;
};

// Builds the problem over `use` observations. `plain` leaves out loss, bounds and manifolds
// (for the Jacobian of the uncertainty analysis).
template <typename M>
void BuildProblem(const ObservationSet& data, const std::vector<size_t>& use, const ModelInfo& info,
                  const JointFitOptions& o, State* s, bool plain, ceres::Problem* problem) {
  const bool in_camera = o.light_frame == "camera";
  const int C = data.channels;
  std::array<bool, 16> is_scale{};
  for (int k = 0; k < M::kNumParams; ++k) is_scale[k] = info.params[k].is_scale;
  for (size_t idx : use) {
    const Observation& obs = data.observations[idx];
    for (int c = 0; c < C; ++c) {
      const int chan = o.per_channel ? c : 0;
      ceres::LossFunction* loss = nullptr;
      if (!plain && o.robust_loss == "huber") loss = new ceres::HuberLoss(3.0);
      if (!plain && o.robust_loss == "cauchy") loss = new ceres::CauchyLoss(3.0);
      const double inv_sigma = 1.0 / Sigma(obs, c, o.relative_noise_floor);
      if (obs.white) {
        if (!o.white_albedo) continue;
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<WhiteRadianceResidual, 1, 3, 1>(
                new WhiteRadianceResidual{&obs, c, inv_sigma, *o.white_albedo, in_camera}),
            loss, s->light.data(), &s->intensity);
      } else {
        problem->AddResidualBlock(
            new ceres::AutoDiffCostFunction<SampleRadianceResidual<M>, 1, M::kNumParams,
                                            M::kNumParams, 3, 1>(
                new SampleRadianceResidual<M>{&obs, c, inv_sigma, in_camera, is_scale}),
            loss, s->shape.data(), s->chan[chan].data(), s->light.data(), &s->intensity);
      }
    }
  }
  if (plain) return;
  std::vector<int> scale_idx, shape_idx;
  for (int k = 0; k < M::kNumParams; ++k) (is_scale[k] ? scale_idx : shape_idx).push_back(k);
  // The shape block holds the shared parameters, each channel block its own albedo-like ones.
  if (problem->HasParameterBlock(s->shape.data())) {
    if (shape_idx.empty()) {
      problem->SetParameterBlockConstant(s->shape.data());
    } else if (!scale_idx.empty()) {
      problem->SetManifold(s->shape.data(), new ceres::SubsetManifold(M::kNumParams, scale_idx));
    }
    for (auto& ch : s->chan) {
      if (!problem->HasParameterBlock(ch.data())) continue;
      if (scale_idx.empty()) {
        problem->SetParameterBlockConstant(ch.data());
      } else if (!shape_idx.empty()) {
        problem->SetManifold(ch.data(), new ceres::SubsetManifold(M::kNumParams, shape_idx));
      }
    }
    for (int k = 0; k < M::kNumParams; ++k) {
      for (double* block : {s->shape.data()}) {
        problem->SetParameterLowerBound(block, k, info.params[k].min);
        problem->SetParameterUpperBound(block, k, info.params[k].max);
      }
      for (auto& ch : s->chan) {
        if (!problem->HasParameterBlock(ch.data())) continue;
        problem->SetParameterLowerBound(ch.data(), k, info.params[k].min);
        problem->SetParameterUpperBound(ch.data(), k, info.params[k].max);
      }
    }
  }
  if (problem->HasParameterBlock(&s->intensity)) {
    problem->SetParameterLowerBound(&s->intensity, 0, 1e-12 * std::abs(s->intensity));
  }
}

template <typename M>
void Solve(const ObservationSet& data, const std::vector<size_t>& use, const ModelInfo& info,
           const JointFitOptions& o, State* s) {
  ceres::Problem problem;
  BuildProblem<M>(data, use, info, o, s, false, &problem);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-10;
  so.logging_type = ceres::SILENT;
  so.num_threads = ResolveThreads(o.threads);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  s->cost = summary.final_cost;
  s->usable = summary.IsSolutionUsable() && std::isfinite(summary.final_cost) &&
              s->light.allFinite() && std::isfinite(s->intensity);
}

template <typename M>
double Predict(const Observation& obs, int c, const State& s, const ModelInfo& info, bool in_camera,
               std::optional<double> white_albedo) {
  double lb[3], ls[3], vs[3];
  LightInBoard(obs, in_camera, s.light.data(), lb);
  const double e = Geometry(obs, lb, ls, vs);
  if (e <= 0) return 0.0;
  if (obs.white) return white_albedo.value_or(0.0) * kInvPi * s.intensity * e;
  double p[M::kNumParams];
  const auto& ch = s.chan[std::min<size_t>(c, s.chan.size() - 1)];
  for (int k = 0; k < M::kNumParams; ++k) p[k] = info.params[k].is_scale ? ch[k] : s.shape[k];
  return M::Evaluate(p, AnglesFromDirections(ls, vs)) * s.intensity * e;
}

std::vector<size_t> Subsample(const ObservationSet& data, size_t max_n) {
  std::vector<size_t> idx;
  const size_t n = data.observations.size();
  const size_t stride = std::max<size_t>(1, (n + max_n - 1) / std::max<size_t>(max_n, 1));
  for (size_t i = 0; i < n; i += stride) idx.push_back(i);
  return idx;
}

template <typename M>
JointFitResult FitModel(const ModelInfo& info, const ObservationSet& data,
                        const std::vector<size_t>& use, const Eigen::Vector3d& light_start,
                        const JointFitOptions& o, bool cross_validate) {
  const bool in_camera = o.light_frame == "camera";
  const int C = data.channels;
  State s;
  for (const auto& p : info.params) s.shape.push_back(p.default_value);
  s.chan.assign(o.per_channel ? C : 1, s.shape);
  s.light = light_start;
  // Intensity start: least squares for the scale of the default model.
  {
    double fy = 0, ff = 0;
    s.intensity = 1.0;
    for (size_t i : use) {
      for (int c = 0; c < C; ++c) {
        const double pred = Predict<M>(data.observations[i], c, s, info, in_camera, o.white_albedo);
        const double w = 1.0 / std::pow(Sigma(data.observations[i], c, o.relative_noise_floor), 2);
        fy += w * pred * data.observations[i].radiance[c];
        ff += w * pred * pred;
      }
    }
    s.intensity = ff > 0 && fy > 0 ? fy / ff : 1.0;
  }
  Solve<M>(data, use, info, o, &s);

  JointFitResult r;
  r.light_frame = o.light_frame;
  r.absolute = o.white_albedo.has_value();
  r.n_observations = use.size();
  BrdfFitResult& m = r.material;
  m.model = info.name;
  for (const auto& p : info.params) m.param_names.push_back(p.name);
  m.n_samples = use.size() * C;
  if (!s.usable) {
    m.converged = false;
    m.message = "the joint fit did not converge";
    m.params.assign(info.num_params(), NAN);
    m.stddev.assign(info.num_params(), std::nullopt);
    return r;
  }
  m.converged = true;
  m.params = s.shape;
  for (int k = 0; k < info.num_params(); ++k) {
    if (info.params[k].is_scale) m.params[k] = s.chan[0][k];
  }
  r.light_position = s.light;
  r.intensity = s.intensity;
  for (int k = 0; k < info.num_params(); ++k) {
    if (!info.params[k].is_scale) continue;
    r.scale_param_names.push_back(info.params[k].name);
  }
  for (const auto& ch : s.chan) {
    std::vector<double> v;
    for (int k = 0; k < info.num_params(); ++k) {
      if (info.params[k].is_scale) v.push_back(ch[k]);
    }
    r.scale_params_per_channel.push_back(v);
  }

  // Uncertainty from the Jacobian of the plain (unweighted-by-loss) residuals, free columns only.
  {
    State plain = s;
    ceres::Problem problem;
    BuildProblem<M>(data, use, info, o, &plain, true, &problem);
    std::vector<double*> blocks;
    struct Column {
      double* block;
      int index;
      double range;
      bool check;
      std::string name;
    };
    std::vector<Column> free_cols;
    const double dist = (s.light - data.observations[use[0]].p_in_board).norm();
    if (problem.HasParameterBlock(plain.shape.data())) {
      blocks.push_back(plain.shape.data());
      for (int k = 0; k < info.num_params(); ++k) {
        if (!info.params[k].is_scale) {
          free_cols.push_back({plain.shape.data(), k, info.params[k].max - info.params[k].min, true,
                               info.params[k].name});
        }
      }
      for (size_t c = 0; c < plain.chan.size(); ++c) {
        if (!problem.HasParameterBlock(plain.chan[c].data())) continue;
        blocks.push_back(plain.chan[c].data());
        for (int k = 0; k < info.num_params(); ++k) {
          if (info.params[k].is_scale) {
            free_cols.push_back(
                {plain.chan[c].data(), k, info.params[k].max - info.params[k].min, true,
                 c == 0 ? info.params[k].name : fmt::format("{}[{}]", info.params[k].name, c)});
          }
        }
      }
    }
    blocks.push_back(plain.light.data());
    for (int k = 0; k < 3; ++k)
      free_cols.push_back({plain.light.data(), k, dist, true, std::string("light_") + "xyz"[k]});
    blocks.push_back(&plain.intensity);
    free_cols.push_back({&plain.intensity, 0, std::abs(s.intensity), true, "intensity"});
    ceres::Problem::EvaluateOptions eo;
    eo.parameter_blocks = blocks;
    ceres::CRSMatrix crs;
    double cost = 0;
    problem.Evaluate(eo, &cost, nullptr, nullptr, &crs);
    // Column offsets of each block in the evaluated Jacobian.
    std::map<double*, int> offset;
    int off = 0;
    for (double* b : blocks) {
      offset[b] = off;
      off += problem.ParameterBlockSize(b);
    }
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, free_cols.size());
    std::map<int, int> col_of;
    for (size_t j = 0; j < free_cols.size(); ++j)
      col_of[offset[free_cols[j].block] + free_cols[j].index] = j;
    for (int row = 0; row < crs.num_rows; ++row) {
      for (int k = crs.rows[row]; k < crs.rows[row + 1]; ++k) {
        const auto it = col_of.find(crs.cols[k]);
        if (it != col_of.end()) J(row, it->second) = crs.values[k];
      }
    }
    std::vector<double> ranges;
    std::vector<bool> checks;
    for (const auto& c : free_cols) {
      ranges.push_back(c.range);
      checks.push_back(c.check);
    }
    const UncertaintyResult u = AnalyzeUncertainty(J, ranges, 2 * cost, checks, o.uncertainty);
    m.covariance = u.covariance;
    m.n_effective = u.rank;
    m.n_params = static_cast<int>(free_cols.size());
    m.stddev.assign(info.num_params(), std::nullopt);
    Eigen::Vector3d light_sd;
    bool light_ok = true;
    for (size_t j = 0; j < free_cols.size(); ++j) {
      const auto& c = free_cols[j];
      if (c.block == plain.light.data()) {
        light_ok = light_ok && u.stddev[j].has_value();
        light_sd[c.index] = u.stddev[j].value_or(NAN);
        if (u.undetermined[j]) r.undetermined_light.push_back(c.name);
      } else if (c.block == &plain.intensity) {
        r.intensity_stddev = u.stddev[j];
        if (u.undetermined[j]) r.undetermined_light.push_back("intensity");
      } else if (c.block == plain.shape.data() || c.block == plain.chan[0].data()) {
        m.stddev[c.index] = u.stddev[j];
        if (u.undetermined[j]) m.undetermined.push_back(c.name);
      } else if (u.undetermined[j]) {
        m.undetermined.push_back(c.name);
      }
    }
    if (light_ok) r.light_stddev = light_sd;
  }
  {
    double e_min = INFINITY, e_max = 0;
    for (size_t i : use) {
      const Observation& obs = data.observations[i];
      if (obs.white) continue;
      double lb[3], ls[3], vs[3];
      LightInBoard(obs, in_camera, s.light.data(), lb);
      const double e = Geometry(obs, lb, ls, vs);
      e_min = std::min(e_min, e);
      e_max = std::max(e_max, e);
    }
    const double contrast = e_min > 0 ? e_max / e_min - 1.0 : 0.0;
    if (contrast < o.min_irradiance_contrast) {
      r.light_stddev.reset();
      r.undetermined_light.push_back("light_distance");
      if (!r.absolute) r.undetermined_light.push_back("intensity");
      r.warnings.push_back(fmt::format(
          "the irradiance varies only {:.2f}% across the sample: the lamp's distance cannot be "
          "measured (only its direction); move the lamp closer",
          100 * contrast));
    }
  }

  // Metrics over the sample observations; per-frame residuals.
  double ssr_w = 0, sq = 0, mean = 0;
  size_t n = 0;
  std::map<int, FrameResidual> frames;
  for (size_t i : use) {
    const Observation& obs = data.observations[i];
    for (int c = 0; c < C; ++c) {
      if (obs.white && !o.white_albedo) continue;
      const double pred = Predict<M>(obs, c, s, info, in_camera, o.white_albedo);
      const double res = pred - obs.radiance[c];
      const double z = res / Sigma(obs, c, o.relative_noise_floor);
      ssr_w += z * z;
      if (!obs.white) {
        sq += res * res;
        mean += obs.radiance[c];
        ++n;
        auto& fr = frames[obs.frame];
        fr.frame = obs.frame;
        ++fr.n;
        fr.rms_sigma += z * z;
        fr.mean_relative += obs.radiance[c] > 0 ? res / obs.radiance[c] : 0.0;
      }
    }
  }
  const double nn = std::max<size_t>(n, 1);
  m.weighted_ssr = ssr_w;
  m.rms = std::sqrt(sq / nn);
  m.rel_rms = mean > 0 ? m.rms / (mean / nn) : m.rms;
  const double n_res = static_cast<double>(use.size() * C);
  m.aic = n_res * std::log(std::max(ssr_w / n_res, 1e-300)) + 2.0 * m.n_effective;
  m.bic = n_res * std::log(std::max(ssr_w / n_res, 1e-300)) + std::log(n_res) * m.n_effective;
  std::vector<double> abs_means;
  for (auto& [f, fr] : frames) {
    fr.rms_sigma = std::sqrt(fr.rms_sigma / fr.n);
    fr.mean_relative /= fr.n;
    fr.file = f < static_cast<int>(data.frame_files.size()) ? data.frame_files[f] : "";
    abs_means.push_back(std::abs(fr.mean_relative));
    r.frames.push_back(fr);
  }
  if (!abs_means.empty()) {
    std::nth_element(abs_means.begin(), abs_means.begin() + abs_means.size() / 2, abs_means.end());
    const double median = abs_means[abs_means.size() / 2];
    for (const auto& fr : r.frames) {
      if (std::abs(fr.mean_relative) > std::max(0.05, 4 * median)) {
        r.warnings.push_back(fmt::format(
            "frame {} ({}): the model is off by {:+.1f}% on average (median frame {:.1f}%): "
            "moved lamp or sample, or a wrong exposure?",
            fr.frame, fr.file, 100 * fr.mean_relative, 100 * median));
      }
    }
  }

  // Cross-validation over held-out frames.
  if (cross_validate) {
    std::vector<int> frame_ids;
    for (const auto& fr : r.frames) frame_ids.push_back(fr.frame);
    const int K = std::min<int>(o.cv_folds, static_cast<int>(frame_ids.size()));
    double cv_sq = 0;
    size_t cv_n = 0;
    for (int fold = 0; K >= 2 && fold < K; ++fold) {
      std::set<int> held;
      for (size_t q = 0; q < frame_ids.size(); ++q) {
        if (static_cast<int>(q % K) == fold) held.insert(frame_ids[q]);
      }
      std::vector<size_t> train, test;
      for (size_t i : use) (held.count(data.observations[i].frame) ? test : train).push_back(i);
      State t = s;
      Solve<M>(data, train, info, o, &t);
      if (!t.usable) t = s;
      for (size_t i : test) {
        const Observation& obs = data.observations[i];
        if (obs.white) continue;
        for (int c = 0; c < C; ++c) {
          const double res =
              Predict<M>(obs, c, t, info, in_camera, o.white_albedo) - obs.radiance[c];
          cv_sq += res * res;
          ++cv_n;
        }
      }
    }
    if (cv_n) m.cv_rms = std::sqrt(cv_sq / cv_n);
  }
  return r;
}

}  // namespace

bool ObservationGeometry(const Observation& o, const JointFitResult& fit, Angles<double>* angles,
                         double* irradiance_factor) {
  double lb[3], ls[3], vs[3];
  LightInBoard(o, fit.light_frame == "camera", fit.light_position.data(), lb);
  *irradiance_factor = Geometry(o, lb, ls, vs);
  if (!(ls[2] > 0)) return false;
  *angles = AnglesFromDirections(ls, vs);
  return true;
}

void JointFitOptions::Check() const {
  if (light_frame != "board" && light_frame != "camera") {
    throw InputError("--light-frame must be board or camera");
  }
  if (criterion != "aic" && criterion != "bic" && criterion != "cv") {
    throw InputError("criterion must be aic, bic or cv");
  }
  if (white_albedo && !(*white_albedo > 0 && *white_albedo <= 1)) {
    throw InputError("--white-albedo must be in (0, 1]");
  }
  if (light_init && !light_init->allFinite()) throw InputError("--light-init must be finite");
  if (robust_loss != "none" && robust_loss != "huber" && robust_loss != "cauchy") {
    throw InputError("robust loss must be none, huber or cauchy");
  }
  if (cv_folds < 2) throw InputError("cv folds must be >= 2");
  for (const auto& c : candidates) FindModel(c);
}

JointFitResult FitJoint(const std::string& model, const ObservationSet& data,
                        const Eigen::Vector3d& light_start, const JointFitOptions& options) {
  options.Check();
  std::vector<size_t> all(data.observations.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  JointFitResult r;
  const ModelInfo& info = FindModel(model);
  VisitModel(model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    r = FitModel<M>(info, data, all, light_start, options, true);
  });
  return r;
}

Eigen::Vector3d InitialLight(const ObservationSet& data, const JointFitOptions& options) {
  if (options.light_init) return *options.light_init;
  std::vector<Eigen::Vector3d> starts;
  if (options.light_frame == "camera") {
    for (const Eigen::Vector3d& d :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, 0, 0), Eigen::Vector3d(-0.1, 0, 0),
          Eigen::Vector3d(0, 0.1, 0), Eigen::Vector3d(0, -0.1, 0)}) {
      starts.push_back(d + Eigen::Vector3d(0, 0, 1e-3));
    }
  } else {
    // In front of the board (z < 0), at the median camera distance, on a cone around the
    // sample's normal.
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    std::vector<double> dist;
    size_t n = 0;
    for (const auto& o : data.observations) {
      if (o.white) continue;
      centre += o.p_in_board;
      dist.push_back((o.camera_in_board - o.p_in_board).norm());
      ++n;
    }
    if (n == 0) throw InputError("no sample observations");
    centre /= n;
    std::nth_element(dist.begin(), dist.begin() + dist.size() / 2, dist.end());
    const double R = dist[dist.size() / 2];
    starts.push_back(centre + Eigen::Vector3d(0, 0, -R));
    for (int a = 0; a < 8; ++a) {
      const double az = a * kPi / 4, el = DegToRad(40);
      starts.push_back(centre + R * Eigen::Vector3d(std::sin(el) * std::cos(az),
                                                    std::sin(el) * std::sin(az), -std::cos(el)));
    }
  }
  JointFitOptions screen = options;
  screen.max_iterations = 50;
  const auto use = Subsample(data, 1500);
  const ModelInfo& info = FindModel("lambert");
  double best_cost = INFINITY;
  Eigen::Vector3d best = starts[0];
  for (const auto& start : starts) {
    const JointFitResult r = FitModel<Lambert>(info, data, use, start, screen, false);
    if (r.material.converged && r.material.weighted_ssr < best_cost) {
      best_cost = r.material.weighted_ssr;
      best = r.light_position;
    }
  }
  spdlog::info("lamp start from {} candidates: ({:.3f}, {:.3f}, {:.3f}) m in the {} frame",
               starts.size(), best.x(), best.y(), best.z(), options.light_frame);
  return best;
}

JointSelectionResult FitAndSelect(const ObservationSet& data, const JointFitOptions& options) {
  options.Check();
  size_t sample = 0;
  std::set<int> frames;
  for (const auto& o : data.observations) {
    sample += !o.white;
    frames.insert(o.frame);
  }
  if (sample == 0) throw InputError("no sample observations to fit");
  const Eigen::Vector3d light0 = InitialLight(data, options);
  const std::vector<std::string> names =
      options.candidates.empty() ? AutoCandidates() : options.candidates;
  const auto use = Subsample(data, options.selection_max_observations);
  JointSelectionResult out;
  out.fits.resize(names.size());
  Progress progress("joint fit candidates", names.size());
  // Candidates in parallel, each solve single-threaded.
  JointFitOptions per = options;
  per.threads = 1;
  std::mutex mutex;
  ParallelFor(names.size(), options.threads, [&](size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      const ModelInfo& info = FindModel(names[k]);
      VisitModel(names[k], [&](auto tag) {
        using M = typename decltype(tag)::type;
        out.fits[k] = FitModel<M>(info, data, use, light0, per, true);
      });
      std::lock_guard<std::mutex> lock(mutex);
      progress.Step();
    }
  });
  progress.Done();
  for (const auto& f : out.fits) out.selection.candidates.push_back(f.material);
  ModelSelectionOptions sel;
  sel.criterion = options.criterion;
  ChooseSimplestAdequate(sel, &out.selection);
  const auto& chosen = out.fits[out.selection.selected];
  spdlog::info("selected {}; refitting on all {} observations", chosen.material.model,
               data.observations.size());
  // The final fit on (up to final_max_observations of) everything.
  const auto final_use = Subsample(data, options.final_max_observations);
  VisitModel(chosen.material.model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    out.final_fit = FitModel<M>(FindModel(chosen.material.model), data, final_use,
                                chosen.light_position, options, true);
  });
  return out;
}

}  // namespace gonio
