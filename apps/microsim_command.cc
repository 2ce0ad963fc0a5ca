// gonio microsim: Monte Carlo BRDF of explicit rough Lambertian microgeometry (V-groove fields,
// Gaussian height fields, pitted planes), at one geometry (JSON) or over an angle grid (CSV).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "common/math.h"
#include "data_synth/microsim.h"

namespace gonio::cli {
namespace {

struct MicrosimArgs {
  std::string surface;
  // vgroove
  double sigma_deg = NAN, slope_deg = NAN, groove_azimuth_deg = NAN;
  // gaussian
  double rms_slope = NAN, rms_height = NAN, corr_length = NAN;
  int grid = 1024;
  int samples_per_corr_length = 16;
  uint64_t surface_seed = 1;
  // pits
  double aperture_deg = NAN, coverage = NAN;
  // estimate
  double albedo = 0.5;
  std::vector<double> theta_i_deg, theta_r_deg, phi_deg;
  int64_t samples = 100000;
  int bounces = 0;
  uint64_t seed = 1;
  int threads = 0;
  std::string table;
  bool directional_albedo = false;
  bool shadowing = false;
};

void RejectFor(const std::string& surface, const char* option, double value) {
  if (!std::isnan(value))
    throw InputError(std::string(option) + " does not apply to --surface " + surface);
}

std::unique_ptr<microsim::Microsurface> MakeSurface(const MicrosimArgs& a) {
  if (a.surface == "vgroove") {
    RejectFor(a.surface, "--rms-slope", a.rms_slope);
    RejectFor(a.surface, "--rms-height", a.rms_height);
    RejectFor(a.surface, "--aperture", a.aperture_deg);
    RejectFor(a.surface, "--coverage", a.coverage);
    microsim::VGrooveOptions o;
    if (!std::isnan(a.slope_deg)) {
      if (!std::isnan(a.sigma_deg)) throw InputError("give --sigma or --slope, not both");
      if (a.slope_deg < 0) throw InputError("--slope must be in [0, 89] deg");
      o.single_slope = DegToRad(a.slope_deg);
    } else if (!std::isnan(a.sigma_deg)) {
      o.sigma = DegToRad(a.sigma_deg);
    } else {
      throw InputError("--surface vgroove needs --sigma DEG (Gaussian slopes) or --slope DEG");
    }
    if (!std::isnan(a.groove_azimuth_deg)) o.azimuth = DegToRad(a.groove_azimuth_deg);
    return microsim::MakeVGrooveField(o);
  }
  if (a.surface == "gaussian") {
    RejectFor(a.surface, "--sigma", a.sigma_deg);
    RejectFor(a.surface, "--slope", a.slope_deg);
    RejectFor(a.surface, "--groove-azimuth", a.groove_azimuth_deg);
    RejectFor(a.surface, "--aperture", a.aperture_deg);
    RejectFor(a.surface, "--coverage", a.coverage);
    microsim::GaussianSurfaceOptions o;
    if (!std::isnan(a.rms_slope)) {
      if (!std::isnan(a.rms_height)) throw InputError("give --rms-slope or --rms-height, not both");
      o.rms_slope = a.rms_slope;
    } else if (!std::isnan(a.rms_height)) {
      const double t = std::isnan(a.corr_length) ? 1.0 : a.corr_length;
      if (!(t > 0) || !(a.rms_height >= 0)) {
        throw InputError("--rms-height must be >= 0 and --corr-length > 0");
      }
      o.rms_slope = std::sqrt(2.0) * a.rms_height / t;  // van Ginneken eq. 5 with eq. 20
    } else {
      throw InputError(
          "--surface gaussian needs --rms-slope R or --rms-height H [--corr-length T]");
    }
    o.grid = a.grid;
    o.samples_per_corr_length = a.samples_per_corr_length;
    o.seed = a.surface_seed;
    return microsim::MakeGaussianSurface(o);
  }
  if (a.surface == "pits") {
    RejectFor(a.surface, "--sigma", a.sigma_deg);
    RejectFor(a.surface, "--slope", a.slope_deg);
    RejectFor(a.surface, "--groove-azimuth", a.groove_azimuth_deg);
    RejectFor(a.surface, "--rms-slope", a.rms_slope);
    RejectFor(a.surface, "--rms-height", a.rms_height);
    microsim::PitsOptions o;
    if (std::isnan(a.aperture_deg)) throw InputError("--surface pits needs --aperture DEG");
    o.aperture = DegToRad(a.aperture_deg);
    o.coverage = std::isnan(a.coverage) ? 1.0 : a.coverage;
    return microsim::MakePittedPlane(o);
  }
  throw InputError("--surface '" + a.surface + "': expected vgroove, gaussian or pits");
}

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

void RunTable(const MicrosimArgs& a, const microsim::Microsurface& surface,
              const microsim::EstimateOptions& options, nlohmann::json out) {
  const std::vector<double> grid = {0, 20, 40, 60, 80};
  const std::vector<double> ti = a.theta_i_deg.empty() ? grid : a.theta_i_deg;
  const std::vector<double> tr = a.theta_r_deg.empty() ? grid : a.theta_r_deg;
  const std::vector<double> ph = a.phi_deg.empty() ? std::vector<double>{0, 90, 180} : a.phi_deg;
  const auto start = std::chrono::steady_clock::now();
  std::ostringstream csv;
  csv << "theta_i_deg,theta_r_deg,phi_deg,brdf,stderr,brdf_single_bounce,stderr_single_bounce\n";
  Progress progress("microsim table", ti.size() * tr.size() * ph.size());
  int64_t rays = 0;
  for (double i : ti) {
    for (double r : tr) {
      for (double p : ph) {
        const auto e =
            microsim::EstimateBrdf(surface, {DegToRad(i), DegToRad(r), DegToRad(p)}, options);
        rays += e.rays;
        csv << Num(i) << ',' << Num(r) << ',' << Num(p) << ',' << Num(e.brdf.mean) << ','
            << Num(e.brdf.stderr_mean) << ',' << Num(e.single_bounce.mean) << ','
            << Num(e.single_bounce.stderr_mean) << '\n';
        progress.Step();
      }
    }
  }
  progress.Done();
  WriteTextAtomically(a.table, csv.str());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out["table"] = a.table;
  out["rows"] = ti.size() * tr.size() * ph.size();
  out["rays"] = rays;
  out["seconds"] = seconds;
  out["rays_per_second"] = seconds > 0 ? rays / seconds : 0.0;
  PrintJson(out);
}

double Single(const std::vector<double>& v, const char* option, double fallback) {
  if (v.empty()) {
    if (std::isnan(fallback)) throw InputError(std::string("microsim needs ") + option + " DEG");
    return fallback;
  }
  if (v.size() > 1) {
    throw InputError(std::string(option) + " takes one value without --table (got " +
                     std::to_string(v.size()) + ")");
  }
  return v[0];
}

void RunMicrosim(const MicrosimArgs& a) {
  // Cheap checks first: generating a Gaussian surface takes a moment.
  if (a.table.empty()) {
    Single(a.theta_i_deg, "--theta-i", NAN);
    if (!a.directional_albedo) Single(a.theta_r_deg, "--theta-r", NAN);
    Single(a.phi_deg, "--phi", 0.0);
  }
  for (const auto* list : {&a.theta_i_deg, &a.theta_r_deg}) {
    for (double deg : *list) {
      if (!(deg >= 0.0 && deg <= 89.9))
        throw InputError("--theta-i/--theta-r must be in [0, 89.9] deg");
    }
  }
  microsim::EstimateOptions options;
  options.albedo = a.albedo;
  options.samples = a.samples;
  options.max_bounces = a.bounces;
  options.seed = a.seed;
  options.threads = a.threads;
  options.Check();
  const auto surface = MakeSurface(a);
  nlohmann::json out = {{"surface", surface->Describe()},
                        {"albedo", a.albedo},
                        {"bounces", a.bounces > 0 ? nlohmann::json(a.bounces) : "unlimited"},
                        {"seed", a.seed}};
  if (!a.table.empty()) {
    RunTable(a, *surface, options, out);
    return;
  }
  const double ti = Single(a.theta_i_deg, "--theta-i", NAN);
  out["theta_i_deg"] = ti;
  if (a.directional_albedo) {
    out["directional_albedo"] =
        microsim::EstimateDirectionalAlbedo(*surface, DegToRad(ti), options).ToJson();
    PrintJson(out);
    return;
  }
  const double tr = Single(a.theta_r_deg, "--theta-r", NAN);
  const double ph = Single(a.phi_deg, "--phi", 0.0);
  const Angles<double> angles{DegToRad(ti), DegToRad(tr), DegToRad(ph)};
  out["theta_r_deg"] = tr;
  out["phi_deg"] = ph;
  const auto e = microsim::EstimateBrdf(*surface, angles, options);
  spdlog::info("microsim {}: {}", surface->name(), e.Report());
  out.update(e.ToJson());
  if (a.shadowing || a.surface == "gaussian") {
    out["shadowing"] = microsim::EstimateShadowing(*surface, angles, options).ToJson();
  }
  PrintJson(out);
}

}  // namespace

void AddMicrosimCommand(CLI::App& app) {
  auto a = std::make_shared<MicrosimArgs>();
  auto* cmd = app.add_subcommand(
      "microsim", "Monte Carlo BRDF of explicit rough Lambertian microgeometry (docs/microsim.md)");
  cmd->add_option("--surface", a->surface, "vgroove, gaussian or pits")->required();
  cmd->add_option("--sigma", a->sigma_deg, "vgroove: slope-area std (Oren-Nayar eq. 26), deg");
  cmd->add_option("--slope", a->slope_deg, "vgroove: one facet slope for every groove, deg");
  cmd->add_option("--groove-azimuth", a->groove_azimuth_deg,
                  "vgroove: fixed azimuth of the groove cross-section from the source, deg "
                  "(default: isotropic)");
  cmd->add_option("--rms-slope", a->rms_slope, "gaussian: rms slope r (van Ginneken eq. 5)");
  cmd->add_option("--rms-height", a->rms_height, "gaussian: rms height (alternative to r)");
  cmd->add_option("--corr-length", a->corr_length, "gaussian: correlation length (default 1)");
  cmd->add_option("--grid", a->grid, "gaussian: vertices per side of the periodic tile")
      ->capture_default_str();
  cmd->add_option("--grid-per-corr-length", a->samples_per_corr_length,
                  "gaussian: grid vertices per correlation length")
      ->capture_default_str();
  cmd->add_option("--surface-seed", a->surface_seed, "gaussian: seed of the realisation")
      ->capture_default_str();
  cmd->add_option("--aperture", a->aperture_deg, "pits: aperture Psi, deg (90 = hemispherical)");
  cmd->add_option("--coverage", a->coverage, "pits: area fraction covered by pits (default 1)");
  cmd->add_option("--albedo", a->albedo, "facet albedo")->capture_default_str();
  cmd->add_option("--theta-i", a->theta_i_deg, "incidence polar angle(s), deg");
  cmd->add_option("--theta-r", a->theta_r_deg, "viewing polar angle(s), deg");
  cmd->add_option("--phi", a->phi_deg, "relative azimuth(s), deg (0 = backscatter side)");
  cmd->add_option("--samples", a->samples, "paths per estimate")->capture_default_str();
  cmd->add_option("--bounces", a->bounces, "surface interactions per path (0 = until absorbed)")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "random seed")->capture_default_str();
  cmd->add_option("--threads", a->threads, "threads (0 = all cores; result is the same)")
      ->capture_default_str();
  cmd->add_option("--table", a->table,
                  "write OUT.csv over the grid of --theta-i x --theta-r x --phi lists");
  cmd->add_flag("--directional-albedo", a->directional_albedo,
                "print the directional albedo for --theta-i instead of the BRDF");
  cmd->add_flag("--shadowing", a->shadowing,
                "add single-bounce shadowing/masking statistics (always on for gaussian)");
  cmd->callback([a] { RunMicrosim(*a); });
}

}  // namespace gonio::cli
