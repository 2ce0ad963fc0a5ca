// JointFitOptions: the option words, Check(), the nuisance terms a fit keeps, and the lamp's
// starting points (estimation/joint/joint_fit.h; docs/pipeline.md "Joint fit").
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/math.h"
#include "common/option_words.h"
#include "common/stats.h"
#include "estimation/joint/joint_fit.h"
#include "estimation/joint/joint_fit_problem.h"
#include "reflectance/registry.h"

namespace gonio {

using joint_fit_internal::Geometry;
using joint_fit_internal::LampInBoard;

namespace {

constexpr OptionWord<NuisanceTerm> kNuisanceWords[] = {
    {NuisanceTerm::kNone, "none"}, {NuisanceTerm::kFit, "fit"}, {NuisanceTerm::kAuto, "auto"}};

}  // namespace

NuisanceTerm ParseNuisanceTerm(const std::string& word, const std::string& option_name) {
  return ParseOptionWord(kNuisanceWords, word, option_name);
}

AmbientTerm ParseAmbientTerm(const std::string& word, const std::string& option_name) {
  return ParseNuisanceTerm(word, option_name);
}

std::string ToString(NuisanceTerm term) { return OptionWordOf(kNuisanceWords, term); }

namespace {
constexpr OptionWord<PatchModel> kPatchWords[] = {{PatchModel::kCentre, "centre"},
                                                  {PatchModel::kAverage, "average"},
                                                  {PatchModel::kAuto, "auto"}};
}  // namespace

PatchModel ParsePatchModel(const std::string& word, const std::string& option_name) {
  return ParseOptionWord(kPatchWords, word, option_name);
}

std::string ToString(PatchModel model) { return OptionWordOf(kPatchWords, model); }

JointFitOptions WithChosenNuisances(const JointFitOptions& options, const JointFitResult& fit) {
  JointFitOptions o = options;
  o.ambient = fit.ambient == AmbientTerm::kFit ? AmbientTerm::kFit : AmbientTerm::kNone;
  o.sample_height = fit.sample_height_offset ? NuisanceTerm::kFit : NuisanceTerm::kNone;
  return o;
}

double PredictedRadiance(const Observation& o, int channel, const JointFitResult& fit,
                         double white_albedo) {
  double lb[3], ls[3], vs[3];
  LampInBoard(o, fit.lamp_frame, fit.lamp_position.data(), lb);
  const double height = o.white ? 0.0 : fit.sample_height_offset.value_or(0);
  const double e = Geometry(o, lb, ls, vs, height);
  if (!(ls[2] > 0) || !(e > 0)) return NAN;
  auto at = [&](const std::vector<double>& v) {
    return channel < static_cast<int>(v.size()) ? v[channel] : 0.0;
  };
  if (o.white) return white_albedo * kInvPi * (fit.intensity * e + at(fit.ambient_irradiance));
  // The per-channel parameters of this channel over the shared ones.
  std::vector<double> p = fit.material.params;
  const size_t c = std::min<size_t>(channel, fit.per_channel_params.size() - 1);
  for (size_t k = 0, j = 0; k < p.size() && !fit.per_channel_params.empty(); ++k) {
    const auto& names = fit.per_channel_param_names;
    if (j < names.size() && names[j] == fit.material.param_names[k]) {
      p[k] = fit.per_channel_params[c][j++];
    }
  }
  // The patch modelled as the fit modelled it (PatchModel).
  const joint_fit_internal::PatchPoints pts =
      joint_fit_internal::PatchPointsOf(o, fit.patch_model == PatchModel::kAverage);
  double lamp = 0;
  VisitModel(fit.material.model, [&](auto tag) {
    using M = typename decltype(tag)::type;
    lamp = joint_fit_internal::LampRadiance<M>(o, lb, p.data(), fit.intensity, height, pts);
  });
  return lamp + at(fit.ambient_sample);
}

void JointFitOptions::Check() const {
  if (white_albedo && !(*white_albedo > 0 && *white_albedo <= 1)) {
    throw InputError("--white-albedo must be in (0, 1]");
  }
  if (lamp_init && !lamp_init->allFinite()) throw InputError("--lamp-init must be finite");
  // A bench lamp is metres away, not kilometres: beyond kMaxLampDistance the start is a typo
  // (and the distance could not be measured anyway: docs/pipeline.md, identifiability).
  if (lamp_init && !(lamp_init->norm() <= kMaxLampDistance)) {
    throw InputError(
        fmt::format("--lamp-init: {:.3g} m from the origin; a lamp start must be "
                    "within {:g} m",
                    lamp_init->norm(), kMaxLampDistance));
  }
  if (!(relative_noise_floor >= 0 && relative_noise_floor < 1)) {
    throw InputError("relative noise floor must be in [0, 1)");
  }
  if (cv_folds < 2) throw InputError("cv folds must be >= 2");
  if (!(search_weighted_ssr_to_beat > 0)) {
    throw InputError("joint fit: the search's cost to beat must be > 0 (or infinite)");
  }
  if (!(function_tolerance > 0 && function_tolerance < 1)) {
    throw InputError("function tolerance must be in (0, 1)");
  }
  if (!(nuisance_margin >= 0) || !(nuisance_min_z >= 0)) {
    throw InputError("nuisance margin and minimum z must be >= 0");
  }
  for (const auto& c : candidates) FindModel(c);
}

JointFitResult FitJoint(const std::string& model, const ObservationSet& data,
                        const Eigen::Vector3d& lamp_start, const JointFitOptions& options) {
  options.Check();
  std::vector<size_t> all(data.observations.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  return joint_fit_internal::FitCandidate(model, data, all, lamp_start, options,
                                          options.criterion == Criterion::kCv);
}

namespace {

// Deterministic lamp starts: near the camera for a lamp fixed in the camera frame; otherwise in
// front of the board (z < 0) at the median camera distance, on the sample's normal and on a
// 40-degree cone around it.
std::vector<Eigen::Vector3d> LampStarts(const ObservationSet& data, LampFrame frame) {
  std::vector<Eigen::Vector3d> starts;
  if (frame == LampFrame::kCamera) {
    for (const Eigen::Vector3d& d :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, 0, 0), Eigen::Vector3d(-0.1, 0, 0),
          Eigen::Vector3d(0, 0.1, 0), Eigen::Vector3d(0, -0.1, 0)}) {
      starts.push_back(d + Eigen::Vector3d(0, 0, 1e-3));
    }
    return starts;
  }
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  std::vector<double> dist;
  for (const auto& o : data.observations) {
    if (o.white) continue;
    centre += o.p_in_board;
    dist.push_back((o.camera_in_board - o.p_in_board).norm());
  }
  if (dist.empty()) throw InputError("no sample observations");
  centre /= static_cast<double>(dist.size());
  const double R = Median(dist);
  starts.push_back(centre + Eigen::Vector3d(0, 0, -R));
  for (int a = 0; a < 8; ++a) {
    const double az = a * kPi / 4, el = DegToRad(40);
    starts.push_back(centre + R * Eigen::Vector3d(std::sin(el) * std::cos(az),
                                                  std::sin(el) * std::sin(az), -std::cos(el)));
  }
  return starts;
}

}  // namespace

Eigen::Vector3d InitialLamp(const ObservationSet& data, const JointFitOptions& options) {
  if (options.lamp_init) return *options.lamp_init;
  const std::vector<Eigen::Vector3d> starts = LampStarts(data, options.lamp_frame);
  JointFitOptions screen = options;
  screen.max_iterations = 50;
  const auto use = joint_fit_internal::Subsample(data, 1500);
  double best_cost = INFINITY;
  Eigen::Vector3d best = starts[0];
  for (const auto& start : starts) {
    const JointFitResult r =
        joint_fit_internal::FitCandidate("lambert", data, use, start, screen, false);
    if (r.material.converged && r.material.weighted_ssr < best_cost) {
      best_cost = r.material.weighted_ssr;
      best = r.lamp_position;
    }
  }
  spdlog::info("lamp start from {} candidates: ({:.3f}, {:.3f}, {:.3f}) m in the {} frame",
               starts.size(), best.x(), best.y(), best.z(), ToString(options.lamp_frame));
  return best;
}

}  // namespace gonio
