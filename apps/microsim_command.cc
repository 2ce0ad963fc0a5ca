// gonio microsim: Monte Carlo BRDF of explicit rough Lambertian microgeometry (V-groove fields,
// Gaussian height fields, pitted planes), at one geometry (JSON) or over an angle grid (CSV).
// The work is data_synth/microsim_job.h; this file only maps flags to a MicrosimJob.
#include <memory>
#include <string>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "data_synth/microsim_job.h"

namespace gonio::cli {
namespace {

struct MicrosimArgs {
  std::string surface_word;
  microsim::MicrosimJob job;
};

}  // namespace

void AddMicrosimCommand(CLI::App& app) {
  auto a = std::make_shared<MicrosimArgs>();
  microsim::SurfaceRequest& sr = a->job.surface;
  microsim::MicrosimJob& job = a->job;
  auto* cmd = app.add_subcommand(
      "microsim", "Monte Carlo BRDF of explicit rough Lambertian microgeometry (docs/microsim.md)");
  cmd->add_option("--surface", a->surface_word, "vgroove, gaussian or pits")->required();
  cmd->add_option("--sigma", sr.sigma_deg, "vgroove: slope-area std (Oren-Nayar eq. 26), deg");
  cmd->add_option("--slope", sr.slope_deg, "vgroove: one facet slope for every groove, deg");
  cmd->add_option("--groove-azimuth", sr.groove_azimuth_deg,
                  "vgroove: fixed azimuth of the groove cross-section from the source, deg "
                  "(default: isotropic)");
  cmd->add_option("--rms-slope", sr.rms_slope, "gaussian: rms slope r (van Ginneken eq. 5)");
  cmd->add_option("--rms-height", sr.rms_height, "gaussian: rms height (alternative to r)");
  cmd->add_option("--corr-length", sr.corr_length, "gaussian: correlation length (default 1)");
  cmd->add_option("--grid", sr.grid, "gaussian: vertices per side of the periodic tile")
      ->capture_default_str();
  cmd->add_option("--grid-per-corr-length", sr.samples_per_corr_length,
                  "gaussian: grid vertices per correlation length")
      ->capture_default_str();
  cmd->add_option("--surface-seed", sr.surface_seed, "gaussian: seed of the realisation")
      ->capture_default_str();
  cmd->add_option("--aperture", sr.aperture_deg, "pits: aperture Psi, deg (90 = hemispherical)");
  cmd->add_option("--coverage", sr.coverage, "pits: area fraction covered by pits (default 1)");
  cmd->add_option("--albedo", job.estimate.albedo, "facet albedo")->capture_default_str();
  cmd->add_option("--theta-i", job.theta_i_deg, "incidence polar angle(s), deg");
  cmd->add_option("--theta-r", job.theta_r_deg, "viewing polar angle(s), deg");
  cmd->add_option("--phi", job.phi_deg, "relative azimuth(s), deg (0 = backscatter side)");
  cmd->add_option("--samples", job.estimate.samples, "paths per estimate")->capture_default_str();
  cmd->add_option("--bounces", job.estimate.max_bounces,
                  "surface interactions per path (0 = until absorbed)")
      ->capture_default_str();
  cmd->add_option("--seed", job.estimate.seed, "random seed")->capture_default_str();
  cmd->add_option("--threads", job.estimate.threads, "threads (0 = all cores; result is the same)")
      ->capture_default_str();
  cmd->add_option("--table", job.table,
                  "write OUT.csv over the grid of --theta-i x --theta-r x --phi lists");
  cmd->add_flag("--directional-albedo", job.directional_albedo,
                "print the directional albedo for --theta-i instead of the BRDF");
  cmd->add_flag("--shadowing", job.shadowing,
                "add single-bounce shadowing/masking statistics (always on for gaussian)");
  cmd->callback([a] {
    a->job.surface.kind = microsim::ParseSurfaceKind(a->surface_word);
    PrintJson(microsim::RunMicrosimJob(a->job));
  });
}

}  // namespace gonio::cli
