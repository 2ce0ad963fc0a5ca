// gonio maps: per-texel albedo, normal, height, roughness and material maps of a textured
// sample with their standard deviations (docs/maps.md).
#include <iostream>
#include <memory>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "common/error.h"
#include "estimation/maps/maps.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

struct MapsArgs {
  std::string session, rectified, camera, photometric, out, lamp, white_albedo;
  std::string lamp_frame = "board", model = "auto", roughness = "auto";
  double texel_mm = 0, normal_prior_deg = 30, noise_floor = 0;
  int max_clusters = 6, hold_out = -1, threads = 0, registration_rounds = 1;
  bool assume_linear = false;
};

MapsOptions ToOptions(const MapsArgs& a) {
  MapsOptions o;
  if (a.model != "auto") o.model = ParseMapsModel(a.model, "--model");
  o.roughness = ParseRoughnessChoice(a.roughness, "--roughness");
  o.sampling.texel_m = 1e-3 * a.texel_mm;
  o.solve.normal_prior_deg = a.normal_prior_deg;
  o.clusters.max_k = a.max_clusters;
  if (!a.lamp.empty()) o.lamp = ParseVector3(a.lamp, "--lamp");
  o.lamp_frame = ParseLampFrame(a.lamp_frame, "--lamp-frame");
  if (!a.white_albedo.empty()) o.white_albedo = ParseNumber(a.white_albedo, "--white-albedo");
  o.relative_noise_floor = a.noise_floor;
  if (a.hold_out >= 0) o.hold_out = a.hold_out;
  o.registration_rounds = a.registration_rounds;
  o.threads = a.threads;
  o.sampling.threads = a.threads;
  o.Check();
  return o;
}

void RunMaps(const MapsArgs& a) {
  if (a.session.empty() == a.rectified.empty()) {
    throw InputError("maps: give either --session DIR (with --camera) or --rectified DIR");
  }
  const MapsOptions o = ToOptions(a);
  MapsResult r;
  if (!a.rectified.empty()) {
    CheckMapsOutput(a.out, {a.rectified});
    r = MapsFromRectified(a.rectified, o);
  } else {
    if (a.hold_out >= 0) throw InputError("--hold-out: only with --rectified");
    const MapsSessionInputs in =
        LoadMapsSessionInputs(a.session, a.camera, a.photometric, a.assume_linear);
    CheckMapsOutput(a.out, {a.session, a.camera, a.photometric});
    r = MapsFromSession(in, o);
  }
  WriteMapsOutputs(r, a.out);
  std::cout << r.Report() << "maps -> " << a.out << "\n";
}

}  // namespace

void AddMapsCommand(CLI::App& app) {
  auto a = std::make_shared<MapsArgs>();
  auto* cmd = app.add_subcommand(
      "maps",
      "Per-texel albedo, normal, height, roughness and material maps of a textured sample, "
      "with standard deviations (docs/maps.md)");
  cmd->add_option("--session", a->session, "Capture session folder (docs/formats.md)");
  cmd->add_option("--rectified", a->rectified,
                  "Instead of --session: rectified views NN.png with camera_pos.txt, "
                  "light_pos.txt, image_size.txt (MaterialGAN's layout)");
  cmd->add_option("--camera", a->camera, "--session: the camera model (.cameramodel)");
  cmd->add_option("--photometric", a->photometric,
                  "--session: photometric.json (default: SESSION/photometric.json)");
  cmd->add_flag("--assume-linear", a->assume_linear,
                "--session without a photometric calibration: assume a linear camera");
  cmd->add_option("--out", a->out, "Output folder (written as a whole)")->required();
  cmd->add_option("--texel", a->texel_mm,
                  "Texel size in mm (default: the images' pixel footprint on the sample)");
  cmd->add_option("--lamp", a->lamp,
                  "X,Y,Z of the lamp in the lamp frame, metres, held fixed (default: from a "
                  "uniform fit of the session, refined with the maps)");
  cmd->add_option("--lamp-frame,--light-frame", a->lamp_frame,
                  "board (the camera moves) or camera (a flash; the board turns)")
      ->capture_default_str();
  cmd->add_option("--white-albedo", a->white_albedo,
                  "Known albedo of the board's white reference: absolute albedo maps");
  cmd->add_option("--model", a->model,
                  "auto, oren-nayar, oren-nayar-qualitative, lambert or diffuse-ggx (auto: "
                  "oren-nayar with --white-albedo, else oren-nayar-qualitative)")
      ->capture_default_str();
  cmd->add_option("--roughness", a->roughness,
                  "auto (by BIC), sample (one), clusters (one per material cluster) or texel")
      ->capture_default_str();
  cmd->add_option("--max-clusters", a->max_clusters, "Most material clusters tried")
      ->capture_default_str();
  cmd->add_option("--normal-prior-deg", a->normal_prior_deg,
                  "RMS tilt of the prior on the relief (the normal's regularisation)")
      ->capture_default_str();
  cmd->add_option("--noise-floor", a->noise_floor,
                  "Relative calibration error added to every radiance's noise, e.g. 0.005")
      ->capture_default_str();
  cmd->add_option("--registration-rounds", a->registration_rounds,
                  "Rounds of registering every view against the maps (0: the poses as located)")
      ->capture_default_str();
  cmd->add_option("--hold-out", a->hold_out,
                  "--rectified: fit without view K and predict it (holdout_prediction.tiff)");
  cmd->add_option("--threads", a->threads, "Threads (0 = all cores)")->capture_default_str();
  cmd->callback([a] { RunMaps(*a); });
}

}  // namespace gonio::cli
