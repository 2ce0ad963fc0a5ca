#include "common/geometry.h"

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

}  // namespace gonio
