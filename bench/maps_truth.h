// A `gonio maps` output judged against the renderer's truth (truth.json "texture" and its truth
// maps, docs/formats.md): the maps' files are read back and every fitted texel compared with
// the truth maps at the same board point. Used by `gonio bench --maps` and the maps tests; it
// reads only files, so it judges the output a user gets.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace gonio::bench {

struct MapsTruthOptions {
  // Texels closer than this to a material edge of the truth (metres), and the texels the maps
  // say mix two materials (edges.png), are left out of the interior figures: their pixels mix
  // two materials.
  double edge_band_m = 0.001;
  // Compare the albedo after one least-squares scale per channel (maps whose albedo is
  // relative: no white reference, or a rectified capture's unknown flash power).
  bool fit_albedo_scale = false;

  void Check() const;  // InputError naming the option
};

struct MapsTruthComparison {
  size_t texels = 0, interior = 0;
  // Texels the maps call material edges (edges.png) that the truth's band leaves in: their
  // RMS relative albedo error and RMS z (is their scaled standard deviation honest?).
  size_t edge = 0;
  double edge_albedo_rel_rms = 0, edge_albedo_rms_z = 0;
  // Interior texels: RMS relative albedo error over texels and channels, RMS normal angle
  // error (deg), RMS roughness error (the model's unit; in deg for sigma), their RMS z
  // (error / reported sd), and the materials found against the truth's count.
  double albedo_rel_rms = 0, normal_rms_deg = 0, roughness_rms = 0, roughness_rms_deg = 0;
  double albedo_rms_z = 0, normal_rms_z = 0, roughness_rms_z = 0;
  double albedo_scale[3] = {1, 1, 1};
  int materials_found = 0, materials_true = 0;
  double material_agreement = 0;  // share of interior texels in their truth material's cluster
  // All fitted texels, edges included.
  double albedo_rel_rms_all = 0, normal_rms_deg_all = 0;
  nlohmann::json ToJson() const;
  std::string Report() const;
};

// maps_dir: a gonio maps output (maps.json and the TIFF maps); truth_dir: the folder with
// truth.json and the truth maps (the session, or the rectified folder). InputError when a file
// is missing.
MapsTruthComparison CompareMapsWithTruth(const std::filesystem::path& maps_dir,
                                         const std::filesystem::path& truth_dir,
                                         const MapsTruthOptions& options = {});

}  // namespace gonio::bench
