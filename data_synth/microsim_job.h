// One `gonio microsim` run as a library call: which microgeometry (a V-groove field, a Gaussian
// height field or a pitted plane, docs/microsim.md) and what to estimate on it (the BRDF at one
// geometry, the directional albedo, or a CSV table over a grid of geometries). The command only
// parses its flags into a MicrosimJob and prints what RunMicrosimJob returns.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "data_synth/microsim.h"
#include "data_synth/microsim_surface.h"

namespace gonio::microsim {

enum class SurfaceKind { kVGroove, kGaussian, kPits };
// "--surface: 'x' is not one of vgroove, gaussian, pits" for any other word.
SurfaceKind ParseSurfaceKind(const std::string& word);
const char* SurfaceKindName(SurfaceKind kind);

// Surface parameters in the command line's units (degrees); NaN = not given. Each applies to
// one kind only; giving another kind's parameter is an InputError naming the option.
struct SurfaceRequest {
  SurfaceKind kind = SurfaceKind::kVGroove;
  double sigma_deg = NAN, slope_deg = NAN, groove_azimuth_deg = NAN;  // vgroove
  double rms_slope = NAN, rms_height = NAN, corr_length = NAN;        // gaussian
  int grid = 1024;
  int samples_per_corr_length = 16;
  uint64_t surface_seed = 1;
  double aperture_deg = NAN, coverage = NAN;  // pits
};

// The microsurface of the request; InputError naming the option for a missing, misplaced or
// out-of-range parameter.
std::unique_ptr<Microsurface> MakeSurface(const SurfaceRequest& request);

struct MicrosimJob {
  SurfaceRequest surface;
  // Geometry in degrees: one value each for a single estimate, lists for a table (empty lists
  // take the table's default grid: 0, 20, ..., 80 deg and phi 0, 90, 180 deg).
  std::vector<double> theta_i_deg, theta_r_deg, phi_deg;
  std::string table;                // CSV path: estimate over the grid and write it there
  bool directional_albedo = false;  // one estimate of the directional albedo at theta_i
  bool shadowing = false;           // add shadowing/masking statistics (always for gaussian)
  EstimateOptions estimate;
  // The cheap checks (angles, option counts), InputError naming the option; MakeSurface makes
  // the rest once the surface is built.
  void Check() const;
};

// Runs the job and returns its result (surface, settings and the estimate; with a table, the
// table's path, rows, rays and speed, the CSV written atomically).
nlohmann::json RunMicrosimJob(const MicrosimJob& job);

}  // namespace gonio::microsim
