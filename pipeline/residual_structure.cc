#include "pipeline/residual_structure.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "common/error.h"
#include "common/math.h"

namespace gonio {
namespace {

// One sample observation's relative residual and where it sits on each axis.
struct Point {
  double relative = 0;
  double axis[3] = {0, 0, 0};  // irradiance factor, theta_r (deg), image radius
};

std::vector<Point> Points(const JointFitResult& fit, const ObservationSet& data,
                          const Eigen::Vector2d& centre, double half_diagonal, size_t max_n) {
  size_t sample = 0;
  for (const auto& o : data.observations) sample += !o.white;
  const size_t stride = std::max<size_t>(1, (sample + max_n - 1) / std::max<size_t>(max_n, 1));
  std::vector<Point> points;
  size_t k = 0;
  for (const auto& o : data.observations) {
    if (o.white || (k++ % stride) != 0 || !(o.radiance[0] > 0)) continue;
    Angles<double> a;
    double e = 0;
    if (!ObservationGeometry(o, fit, &a, &e) || !(e > 0)) continue;
    const double predicted = PredictedRadiance(o, 0, fit, 0.0);
    if (!std::isfinite(predicted)) continue;
    Point p;
    // Clipped: a stray pixel (a tag edge the robust loss ignored) must not make a trend.
    p.relative = std::clamp((predicted - o.radiance[0]) / o.radiance[0], -0.5, 0.5);
    p.axis[0] = e;
    p.axis[1] = RadToDeg(a.theta_r);
    p.axis[2] = std::hypot(o.px - centre.x(), o.py - centre.y()) / half_diagonal;
    points.push_back(p);
  }
  return points;
}

ResidualTrend Trend(ResidualAxis axis, std::vector<Point> points, double overall, double floor,
                    const ResidualStructureOptions& o) {
  ResidualTrend t;
  t.axis = axis;
  const int a = static_cast<int>(axis);
  std::sort(points.begin(), points.end(),
            [a](const Point& x, const Point& y) { return x.axis[a] < y.axis[a]; });
  const size_t n = points.size();
  const double median_axis = points[n / 2].axis[a];
  for (int b = 0; b < o.bins; ++b) {
    const size_t begin = n * b / o.bins, end = n * (b + 1) / o.bins;
    if (end <= begin + 1) continue;
    double sum = 0, sum_sq = 0, where = 0;
    for (size_t i = begin; i < end; ++i) {
      sum += points[i].relative;
      sum_sq += points[i].relative * points[i].relative;
      where += points[i].axis[a];
    }
    const double m = static_cast<double>(end - begin);
    const double mean = sum / m, var = std::max(0.0, sum_sq / m - mean * mean);
    // The irradiance axis relative to its median (the lamp's units are arbitrary).
    t.centre.push_back(axis == ResidualAxis::kIrradiance ? where / m / median_axis : where / m);
    t.mean.push_back(mean - overall);
    t.stderr_.push_back(std::sqrt(var / (m - 1)));
  }
  t.threshold = o.floor_multiple * floor;
  for (size_t b = 0; b < t.mean.size(); ++b) {
    t.amplitude = std::max(t.amplitude, std::abs(t.mean[b]));
    if (std::abs(t.mean[b]) > t.threshold && std::abs(t.mean[b]) > o.min_z * t.stderr_[b]) {
      t.structured = true;
    }
  }
  return t;
}

}  // namespace

std::string ToString(ResidualAxis axis) {
  switch (axis) {
    case ResidualAxis::kIrradiance:
      return "irradiance";
    case ResidualAxis::kView:
      return "view";
    case ResidualAxis::kPosition:
      return "image position";
  }
  return "unknown";
}

void ResidualStructureOptions::Check() const {
  if (bins < 2) throw InputError("residual structure: bins must be >= 2");
  if (!(floor_multiple > 0)) throw InputError("residual structure: floor_multiple must be > 0");
  if (!(min_z > 0)) throw InputError("residual structure: min_z must be > 0");
  if (max_observations < 100) throw InputError("residual structure: max_observations >= 100");
}

nlohmann::json ResidualTrend::ToJson() const {
  return {{"axis", ToString(axis)},  {"bin_centre", centre},   {"bin_mean_relative", mean},
          {"bin_stderr", stderr_},   {"amplitude", amplitude}, {"threshold", threshold},
          {"structured", structured}};
}

std::string ResidualStructure::Report() const {
  std::string s;
  for (const auto& t : trends) {
    s += fmt::format("residuals against {}: up to {:.2f}% from the mean ({} above {:.2f}%)\n",
                     ToString(t.axis), 100 * t.amplitude, t.structured ? "structure:" : "none",
                     100 * t.threshold);
  }
  return s;
}

nlohmann::json ResidualStructure::ToJson() const {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& t : trends) j.push_back(t.ToJson());
  return j;
}

ResidualStructure FindResidualStructure(const JointFitResult& fit, const ObservationSet& data,
                                        double floor, const Eigen::Vector2d& image_centre,
                                        double half_diagonal_px,
                                        const ResidualStructureOptions& o) {
  o.Check();
  ResidualStructure r;
  if (!fit.material.converged) return r;
  const std::vector<Point> points =
      Points(fit, data, image_centre, std::max(half_diagonal_px, 1.0), o.max_observations);
  if (points.size() < static_cast<size_t>(10 * o.bins)) return r;
  double overall = 0;
  for (const auto& p : points) overall += p.relative;
  overall /= points.size();
  for (ResidualAxis axis :
       {ResidualAxis::kIrradiance, ResidualAxis::kView, ResidualAxis::kPosition}) {
    r.trends.push_back(Trend(axis, points, overall, floor, o));
  }
  return r;
}

}  // namespace gonio
