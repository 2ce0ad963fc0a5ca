#include "data_synth/microsim_job.h"

#include <chrono>
#include <cstdio>
#include <sstream>
#include <utility>

#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "common/math.h"
#include "common/option_words.h"

namespace gonio::microsim {
namespace {

constexpr OptionWord<SurfaceKind> kSurfaceWords[] = {{SurfaceKind::kVGroove, "vgroove"},
                                                     {SurfaceKind::kGaussian, "gaussian"},
                                                     {SurfaceKind::kPits, "pits"}};

void RejectFor(const SurfaceRequest& r, const char* option, double value) {
  if (!std::isnan(value)) {
    throw InputError(std::string(option) + " does not apply to --surface " +
                     SurfaceKindName(r.kind));
  }
}

std::unique_ptr<Microsurface> MakeVGrooves(const SurfaceRequest& r) {
  RejectFor(r, "--rms-slope", r.rms_slope);
  RejectFor(r, "--rms-height", r.rms_height);
  RejectFor(r, "--aperture", r.aperture_deg);
  RejectFor(r, "--coverage", r.coverage);
  VGrooveOptions o;
  if (!std::isnan(r.slope_deg)) {
    if (!std::isnan(r.sigma_deg)) throw InputError("give --sigma or --slope, not both");
    if (r.slope_deg < 0) throw InputError("--slope must be in [0, 89] deg");
    o.single_slope = DegToRad(r.slope_deg);
  } else if (!std::isnan(r.sigma_deg)) {
    o.sigma = DegToRad(r.sigma_deg);
  } else {
    throw InputError("--surface vgroove needs --sigma DEG (Gaussian slopes) or --slope DEG");
  }
  if (!std::isnan(r.groove_azimuth_deg)) o.azimuth = DegToRad(r.groove_azimuth_deg);
  return MakeVGrooveField(o);
}

std::unique_ptr<Microsurface> MakeGaussian(const SurfaceRequest& r) {
  RejectFor(r, "--sigma", r.sigma_deg);
  RejectFor(r, "--slope", r.slope_deg);
  RejectFor(r, "--groove-azimuth", r.groove_azimuth_deg);
  RejectFor(r, "--aperture", r.aperture_deg);
  RejectFor(r, "--coverage", r.coverage);
  GaussianSurfaceOptions o;
  if (!std::isnan(r.rms_slope)) {
    if (!std::isnan(r.rms_height)) throw InputError("give --rms-slope or --rms-height, not both");
    o.rms_slope = r.rms_slope;
  } else if (!std::isnan(r.rms_height)) {
    const double t = std::isnan(r.corr_length) ? 1.0 : r.corr_length;
    if (!(t > 0) || !(r.rms_height >= 0)) {
      throw InputError("--rms-height must be >= 0 and --corr-length > 0");
    }
    o.rms_slope = std::sqrt(2.0) * r.rms_height / t;  // van Ginneken eq. 5 with eq. 20
  } else {
    throw InputError("--surface gaussian needs --rms-slope R or --rms-height H [--corr-length T]");
  }
  o.grid = r.grid;
  o.samples_per_corr_length = r.samples_per_corr_length;
  o.seed = r.surface_seed;
  return MakeGaussianSurface(o);
}

std::unique_ptr<Microsurface> MakePits(const SurfaceRequest& r) {
  RejectFor(r, "--sigma", r.sigma_deg);
  RejectFor(r, "--slope", r.slope_deg);
  RejectFor(r, "--groove-azimuth", r.groove_azimuth_deg);
  RejectFor(r, "--rms-slope", r.rms_slope);
  RejectFor(r, "--rms-height", r.rms_height);
  PitsOptions o;
  if (std::isnan(r.aperture_deg)) throw InputError("--surface pits needs --aperture DEG");
  o.aperture = DegToRad(r.aperture_deg);
  o.coverage = std::isnan(r.coverage) ? 1.0 : r.coverage;
  return MakePittedPlane(o);
}

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

// The one value of an angle list outside a table run (fallback when empty; NaN: required).
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

void RunTable(const MicrosimJob& job, const Microsurface& surface, nlohmann::json* out) {
  const std::vector<double> grid = {0, 20, 40, 60, 80};
  const std::vector<double> ti = job.theta_i_deg.empty() ? grid : job.theta_i_deg;
  const std::vector<double> tr = job.theta_r_deg.empty() ? grid : job.theta_r_deg;
  const std::vector<double> ph =
      job.phi_deg.empty() ? std::vector<double>{0, 90, 180} : job.phi_deg;
  const auto start = std::chrono::steady_clock::now();
  std::ostringstream csv;
  csv << "theta_i_deg,theta_r_deg,phi_deg,brdf,stderr,brdf_single_bounce,stderr_single_bounce\n";
  Progress progress("microsim table", ti.size() * tr.size() * ph.size());
  int64_t rays = 0;
  for (double i : ti) {
    for (double r : tr) {
      for (double p : ph) {
        const auto e = EstimateBrdf(surface, {DegToRad(i), DegToRad(r), DegToRad(p)}, job.estimate);
        rays += e.rays;
        csv << Num(i) << ',' << Num(r) << ',' << Num(p) << ',' << Num(e.brdf.mean) << ','
            << Num(e.brdf.stderr_mean) << ',' << Num(e.single_bounce.mean) << ','
            << Num(e.single_bounce.stderr_mean) << '\n';
        progress.Step();
      }
    }
  }
  progress.Done();
  WriteTextAtomically(job.table, csv.str());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  (*out)["table"] = job.table;
  (*out)["rows"] = ti.size() * tr.size() * ph.size();
  (*out)["rays"] = rays;
  (*out)["seconds"] = seconds;
  (*out)["rays_per_second"] = seconds > 0 ? rays / seconds : 0.0;
}

}  // namespace

SurfaceKind ParseSurfaceKind(const std::string& word) {
  return ParseOptionWord(kSurfaceWords, word, "--surface");
}

const char* SurfaceKindName(SurfaceKind kind) {
  for (const auto& [k, w] : kSurfaceWords) {
    if (k == kind) return w;
  }
  return "?";
}

std::unique_ptr<Microsurface> MakeSurface(const SurfaceRequest& request) {
  switch (request.kind) {
    case SurfaceKind::kVGroove:
      return MakeVGrooves(request);
    case SurfaceKind::kGaussian:
      return MakeGaussian(request);
    case SurfaceKind::kPits:
      return MakePits(request);
  }
  throw InputError("--surface: unknown kind");
}

void MicrosimJob::Check() const {
  if (table.empty()) {
    Single(theta_i_deg, "--theta-i", NAN);
    if (!directional_albedo) Single(theta_r_deg, "--theta-r", NAN);
    Single(phi_deg, "--phi", 0.0);
  }
  for (const auto* list : {&theta_i_deg, &theta_r_deg}) {
    for (double deg : *list) {
      if (!(deg >= 0.0 && deg <= 89.9))
        throw InputError("--theta-i/--theta-r must be in [0, 89.9] deg");
    }
  }
  for (double deg : phi_deg) {
    if (!std::isfinite(deg)) throw InputError("--phi must be a finite number of degrees");
  }
  estimate.Check();
}

nlohmann::json RunMicrosimJob(const MicrosimJob& job) {
  job.Check();  // cheap checks first: generating a Gaussian surface takes a moment
  const auto surface = MakeSurface(job.surface);
  const EstimateOptions& o = job.estimate;
  nlohmann::json out = {
      {"surface", surface->Describe()},
      {"albedo", o.albedo},
      {"bounces", o.max_bounces > 0 ? nlohmann::json(o.max_bounces) : "unlimited"},
      {"seed", o.seed}};
  if (!job.table.empty()) {
    RunTable(job, *surface, &out);
    return out;
  }
  const double ti = Single(job.theta_i_deg, "--theta-i", NAN);
  out["theta_i_deg"] = ti;
  if (job.directional_albedo) {
    out["directional_albedo"] = EstimateDirectionalAlbedo(*surface, DegToRad(ti), o).ToJson();
    return out;
  }
  const double tr = Single(job.theta_r_deg, "--theta-r", NAN);
  const double ph = Single(job.phi_deg, "--phi", 0.0);
  const Angles<double> angles{DegToRad(ti), DegToRad(tr), DegToRad(ph)};
  out["theta_r_deg"] = tr;
  out["phi_deg"] = ph;
  const auto e = EstimateBrdf(*surface, angles, o);
  spdlog::info("microsim {}: {}", surface->name(), e.Report());
  out.update(e.ToJson());
  if (job.shadowing || job.surface.kind == SurfaceKind::kGaussian) {
    out["shadowing"] = EstimateShadowing(*surface, angles, o).ToJson();
  }
  return out;
}

}  // namespace gonio::microsim
