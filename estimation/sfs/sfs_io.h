// Files of `gonio sfs`: the input folder written by `gonio synth --preset sfs-*`
// (docs/formats.md, "Shape-from-shading folder") and the outputs (docs/sfs.md).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "estimation/sfs/sfs.h"

namespace gonio {

struct SfsInputPaths {
  std::filesystem::path image, camera, material, mask;
  std::filesystem::path lamp_json;  // optional: position, intensity, radiance_per_dn
  std::string lamp;                 // "X,Y,Z" (camera frame, m) or "collocated"; overrides
  std::filesystem::path truth_dir;  // optional: depth.tiff, normals.tiff
  double distance = 0;              // anchor depth (m); 0: from absolute radiometry
  // A folder written by gonio synth: fills every empty path above from it.
  void FillFromFolder(const std::filesystem::path& dir);
};

struct SfsInput {
  SfsProblem problem;
  double radiance_per_dn = 1;  // 1 when unknown (relative radiance)
  double black_level = 0;
  bool absolute = false;  // radiance_per_dn known: radiance in W m^-2 sr^-1
  std::string anchor_source;
  std::string image_path;
};

// Reads and validates everything; InputError naming the file or option on bad input.
// `reflectance` "lambert" accepts a missing material (then --distance is required).
SfsInput LoadSfsInput(const SfsInputPaths& paths, const std::string& reflectance);

struct SfsTruthComparison {
  double mean_normal_error_deg = 0, p95_normal_error_deg = 0, median_normal_error_deg = 0;
  double median_depth_error_rel = 0;  // |z - z_true| / z_true
  size_t pixels = 0;
  cv::Mat depth, normals;  // CV_64F, CV_64FC3 (x, y, z)
};

// Compares with DIR/depth.tiff and DIR/normals.tiff; nullopt when the folder has none.
std::optional<SfsTruthComparison> CompareWithTruth(const std::filesystem::path& truth_dir,
                                                   const SfsInput& input, const SfsResult& result);

// The same image solved with a Lambertian prior (gonio sfs --compare-lambert), for the
// comparison of Oren-Nayar figs. 22-23.
struct SfsLambertComparison {
  SfsResult lambert;
  std::optional<SfsTruthComparison> truth;
};

// Writes depth.tiff, normals.png, rerender.png, cross_section.png, depth_section.png,
// normal_error.png (with truth) and sfs.json into `out`; with `comparison` also
// comparison_depth.png (recovered depth of both priors and truth along the cross-section row)
// and a "comparison" block in sfs.json. Returns the sfs.json content.
nlohmann::json WriteSfsOutputs(const std::filesystem::path& out, const SfsInput& input,
                               const SfsResult& result,
                               const std::optional<SfsTruthComparison>& truth,
                               const SfsLambertComparison* comparison = nullptr);

}  // namespace gonio
