// The vignetting module's small public pieces (calib/photometry/vignette.h): its options'
// check, the model's names, and the poses file gonio locate writes.
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/photometry/vignette.h"
#include "common/error.h"
#include "common/geometry.h"
#include "common/io.h"

namespace gonio {

const char* ToString(VignetteModel m) { return m == VignetteModel::kMap ? "map" : "radial"; }

VignetteModel ParseVignetteModel(const std::string& word, const std::string& option) {
  if (word == "map") return VignetteModel::kMap;
  if (word == "radial") return VignetteModel::kRadial;
  throw InputError(option + " must be 'map' or 'radial', got '" + word + "'");
}

void VignetteOptions::Check() const {
  if (cell_px < 2) throw InputError("vignette cell_px must be >= 2");
  if (sample_step_px < 1) throw InputError("vignette sample_step_px must be >= 1");
  if (!(albedo_cell_m > 0)) throw InputError("vignette albedo_cell_m must be > 0");
  if (!(tag_margin_m >= 0)) throw InputError("vignette tag_margin_m must be >= 0");
  if (min_samples_per_cell < 1) throw InputError("vignette min_samples_per_cell must be >= 1");
  if (!(min_coverage >= 0 && min_coverage <= 1)) {
    throw InputError("vignette min_coverage must be in [0, 1]");
  }
  if (max_iterations < 1) throw InputError("vignette max_iterations must be >= 1");
}

std::vector<std::pair<std::string, Rigid3d>> ReadPoses(const std::filesystem::path& path) {
  const nlohmann::json j = ReadJsonFile(path);
  if (!j.contains("frames") || !j["frames"].is_array()) {
    throw InputError(path.string() + ": missing array 'frames'");
  }
  std::vector<std::pair<std::string, Rigid3d>> out;
  for (const auto& f : j["frames"]) {
    if (!f.contains("file") || !f.contains("cam_from_board")) {
      throw InputError(path.string() + ": a frame lacks 'file' or 'cam_from_board'");
    }
    try {
      out.emplace_back(f["file"].get<std::string>(), RigidFromJson(f["cam_from_board"]));
    } catch (const nlohmann::json::exception& e) {
      throw InputError(path.string() + ": malformed cam_from_board: " + e.what());
    }
  }
  return out;
}

}  // namespace gonio
