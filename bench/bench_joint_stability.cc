// Stability of the joint BRDF + lamp fit where it fails: the lamp far away, few views, heavy
// noise, unmasked saturation. Observations are synthesized directly from the geometry (no
// image rendering), so the sweep takes seconds.
#include <cmath>
#include <random>

#include <fmt/format.h>

#include "bench/bench_lib.h"
#include "common/math.h"
#include "estimation/joint/joint_fit.h"
#include "reflectance/registry.h"

namespace gonio::bench {
namespace {

struct JointCase {
  std::string axis, value;
  double lamp_distance = 0.5;
  int views = 24;
  double noise = 0.01;
  double clip = INFINITY;  // radiance above this fraction of the maximum is clipped
};

ObservationSet Synthesize(const JointCase& c, Eigen::Vector3d* lamp, unsigned seed) {
  const Eigen::Vector3d centre(0.155, 0.095, 0.0);
  // The default preset's geometry: lamp 35 deg off the sample normal (-z), cameras on rings.
  const double off = DegToRad(35);
  *lamp = centre + c.lamp_distance * Eigen::Vector3d(-std::sin(off), 0.0, -std::cos(off));
  const double intensity = c.lamp_distance * c.lamp_distance / 0.25;  // same irradiance
  const double albedo = 0.6, sigma = DegToRad(30), white = 0.8;
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  ObservationSet set;
  const double rings[] = {15, 32, 48, 62};
  std::vector<Eigen::Vector3d> cams;
  for (int k = 0; k < c.views; ++k) {
    const double polar = DegToRad(rings[k % 4]), az = 2 * kPi * k / std::max(1, c.views) + 0.3;
    cams.push_back(centre + 0.45 * Eigen::Vector3d(std::sin(polar) * std::cos(az),
                                                   std::sin(polar) * std::sin(az),
                                                   -std::cos(polar)));
  }
  std::vector<Observation> obs;
  double peak = 0;
  for (size_t f = 0; f < cams.size(); ++f) {
    set.frame_files.push_back(fmt::format("view_{}", f));
    for (int iy = 0; iy < 7; ++iy) {
      for (int ix = 0; ix < 13; ++ix) {
        Observation o;
        o.frame = static_cast<int>(f);
        o.white = ix < 3;
        o.p_in_board = o.white ? Eigen::Vector3d(0.04 + 0.01 * ix, 0.045 + 0.016 * iy, 0)
                               : Eigen::Vector3d(0.08 + 0.015 * (ix - 3), 0.045 + 0.016 * iy, 0);
        o.camera_in_board = cams[f];
        const Eigen::Vector3d l = *lamp - o.p_in_board, v = cams[f] - o.p_in_board;
        const double ls[3] = {l.x(), -l.y(), -l.z()}, vs[3] = {v.x(), -v.y(), -v.z()};
        const double e = intensity * ls[2] / std::pow(l.norm(), 3);
        const double params[2] = {albedo, sigma};
        const double f_r =
            o.white ? white * kInvPi : OrenNayar::Evaluate(params, AnglesFromDirections(ls, vs));
        const double L = f_r * e;
        peak = std::max(peak, L);
        o.radiance = {L * (1 + c.noise * gauss(rng))};
        o.variance = {std::pow(c.noise * L, 2)};
        obs.push_back(o);
      }
    }
  }
  for (auto& o : obs) o.radiance[0] = std::min(o.radiance[0], c.clip * peak);
  set.observations = obs;
  return set;
}

StabilityCell RunCase(const JointCase& c) {
  StabilityCell cell;
  cell.subject = "joint-fit:oren-nayar";
  cell.method = "FitJoint";
  cell.axis = c.axis;
  cell.value = c.value;
  Eigen::Vector3d lamp;
  const ObservationSet data = Synthesize(c, &lamp, 7);
  JointFitOptions o;
  o.white_albedo = 0.8;
  o.lamp_init =
      lamp + 0.3 * (lamp - Eigen::Vector3d(0.155, 0.095, 0)).norm() * Eigen::Vector3d::UnitX();
  try {
    const JointFitResult r = FitJoint("oren-nayar", data, *o.lamp_init, o);
    const double sigma_err = RadToDeg(std::abs(r.material.params[1] - DegToRad(30)));
    const double albedo_err = std::abs(r.material.params[0] - 0.6) / 0.6;
    std::string undetermined;
    for (const auto& u : r.material.undetermined) undetermined += u + " ";
    for (const auto& u : r.undetermined_lamp) undetermined += u + " ";
    cell.detail =
        fmt::format("sigma err {:.2f} deg, albedo err {:.1f}%{}", sigma_err, 100 * albedo_err,
                    undetermined.empty() ? "" : "; undetermined: " + undetermined);
    const bool finite = std::isfinite(sigma_err) && std::isfinite(albedo_err);
    cell.status = !finite                                                           ? "error"
                  : (!undetermined.empty() || sigma_err > 2.0 || albedo_err > 0.03) ? "degraded"
                                                                                    : "valid";
  } catch (const std::exception& e) {
    cell.status = "error";
    cell.detail = e.what();
  }
  return cell;
}

}  // namespace

StabilityHook JointFitStabilityHook() {
  return {"joint-fit", [](const BenchSizes&) {
            std::vector<JointCase> cases;
            for (double d : {0.5, 2.0, 10.0, 50.0}) {
              cases.push_back({"lamp distance", fmt::format("{} m", d), d});
            }
            for (int v : {24, 6, 2, 1}) cases.push_back({"views", fmt::format("{}", v), 0.5, v});
            for (double n : {0.01, 0.05, 0.2}) {
              cases.push_back({"noise", fmt::format("{:.0f}%", 100 * n), 0.5, 24, n});
            }
            for (double clip : {1.0, 0.9, 0.7}) {
              cases.push_back(
                  {"saturation", fmt::format("clip {:.0f}%", 100 * clip), 0.5, 24, 0.01, clip});
            }
            std::vector<StabilityCell> cells;
            for (const auto& c : cases) cells.push_back(RunCase(c));
            return cells;
          }};
}

}  // namespace gonio::bench
