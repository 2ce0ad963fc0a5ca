#include "common/geometry.h"

#include <algorithm>
#include <cmath>

#include "common/error.h"

namespace gonio {

nlohmann::json ToJson(const Rigid3d& T) {
  nlohmann::json R = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) R.push_back({T.R(r, 0), T.R(r, 1), T.R(r, 2)});
  return {{"R", R}, {"t", {T.t.x(), T.t.y(), T.t.z()}}};
}

Rigid3d RigidFromJson(const nlohmann::json& j) {
  Rigid3d T;
  if (!j.contains("R") || !j.contains("t") || j["R"].size() != 3 || j["t"].size() != 3) {
    throw InputError("transform must be {\"R\": 3x3, \"t\": [x, y, z]}");
  }
  for (int r = 0; r < 3; ++r) {
    if (j["R"][r].size() != 3) throw InputError("transform R must be 3x3");
    for (int c = 0; c < 3; ++c) T.R(r, c) = j["R"][r][c].get<double>();
  }
  for (int i = 0; i < 3; ++i) T.t(i) = j["t"][i].get<double>();
  return T;
}

double SignedDistanceInPolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  if (poly.empty()) return -INFINITY;  // no polygon: every point outside
  bool inside = false;
  double dmin = INFINITY;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
    const Eigen::Vector2d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
    dmin = std::min(dmin, (a + t * ab - p).norm());
  }
  return inside ? dmin : -dmin;
}

}  // namespace gonio
