// gonio synth: render a synthetic capture session (board scenes) or a shape-from-shading
// input folder (sfs scenes) from scene.json or a named preset, with truth.json.
#include <filesystem>
#include <memory>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "calib/photometry/synth_photometric.h"
#include "common/error.h"
#include "common/io.h"
#include "common/log.h"
#include "data_synth/board_renderer.h"
#include "data_synth/rectified_views.h"
#include "data_synth/scene.h"
#include "data_synth/sfs_renderer.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

struct SynthArgs {
  std::string scene_file, preset, out_dir, write_scene;
  double sfs_lamp_offaxis_deg = 0.0;
  int threads = 0;
  int rectified = 0;
  long long seed = -1;
  bool no_noise = false;
  bool with_calibration = false;
};

void RunSynth(const SynthArgs& args) {
  if (args.scene_file.empty() == args.preset.empty()) {
    throw InputError("synth: give exactly one of --scene FILE or --preset NAME");
  }
  if (args.out_dir.empty() && args.write_scene.empty()) {
    throw InputError("synth: give --out DIR (render) and/or --write-scene FILE");
  }
  synth::Scene scene;
  if (!args.preset.empty()) {
    synth::PresetOptions options;
    options.sfs_lamp_offaxis_deg = args.sfs_lamp_offaxis_deg;
    scene = synth::PresetScene(args.preset, options);
  } else {
    scene = synth::SceneFromJson(ReadJsonFile(args.scene_file), args.scene_file);
  }
  if (args.seed >= 0) scene.seed = static_cast<uint64_t>(args.seed);
  if (args.no_noise) scene.photometric.noise = false;
  if (!args.write_scene.empty()) WriteJsonAtomically(args.write_scene, synth::SceneToJson(scene));
  if (args.out_dir.empty()) {
    // Not validated here: a preset may name a model registered only in a newer build.
    PrintJson({{"scene", args.write_scene}});
    return;
  }
  if (args.rectified > 0) {
    const auto r = synth::RenderRectifiedViews(scene, args.rectified, args.out_dir, args.threads);
    PrintJson({{"out", args.out_dir},
               {"type", "rectified"},
               {"views", r.views},
               {"size", r.size},
               {"seconds", r.seconds}});
    return;
  }
  if (scene.type == synth::SceneType::kSfs) {
    const auto r = synth::RenderSfsScene(scene, args.out_dir, args.threads);
    spdlog::info("synth: {}", r.Report());
    PrintJson({{"out", args.out_dir},
               {"type", "sfs"},
               {"seconds", r.seconds},
               {"mask_pixels", r.mask_pixels}});
  } else {
    const auto r = synth::RenderBoardSession(scene, args.out_dir, args.threads);
    spdlog::info("synth: {}", r.Report());
    if (args.with_calibration) {
      // What a user measures once for the camera (gonio photometric); here the renderer's own
      // chain, so the session runs through gonio run / maps without a calibration step.
      const fs::path dir(args.out_dir);
      PhotometricFromSynthTruth(ReadJsonFile(dir / "truth.json"), scene.camera.width,
                                scene.camera.height)
          .Write(dir / "photometric.json");
    }
    PrintJson({{"out", args.out_dir},
               {"type", "board"},
               {"frames", r.frames},
               {"seconds", r.seconds},
               {"supersampled_pixels", r.supersampled_pixels}});
  }
}

}  // namespace

void AddSynthCommand(CLI::App& app) {
  auto args = std::make_shared<SynthArgs>();
  auto* cmd = app.add_subcommand(
      "synth", "Render a synthetic session (board) or sfs input folder with truth.json");
  cmd->add_option("--scene", args->scene_file, "scene.json (docs/formats.md)");
  cmd->add_option("--preset", args->preset,
                  "default, flat-field, exposure-sweep, sfs-sphere, sfs-vase, sfs-bumps, "
                  "flash, flash-8bit, raised-sample, ambient, textured, textured-3mat, "
                  "textured-flash");
  cmd->add_option("--out", args->out_dir, "Output folder");
  cmd->add_option("--write-scene", args->write_scene, "Write the scene (e.g. a preset) as JSON");
  cmd->add_option("--sfs-lamp-offaxis-deg,--sfs-light-offaxis-deg", args->sfs_lamp_offaxis_deg,
                  "sfs presets: lamp turned this far off the camera axis (0 = collocated)")
      ->capture_default_str();
  cmd->add_option("--seed", args->seed, "Override the scene's noise seed");
  cmd->add_flag("--no-noise", args->no_noise, "Turn shot and read noise off");
  cmd->add_flag("--with-calibration", args->with_calibration,
                "Board scenes: also write the renderer's photometric chain as the session's "
                "photometric.json (the calibration a user measures once with gonio photometric)");
  cmd->add_option("--rectified", args->rectified,
                  "Textured scenes: write MaterialGAN's rectified layout (N x N views of the "
                  "sample's square, NN.png, camera_pos.txt, light_pos.txt) instead of a session")
      ->check(CLI::Range(16, 4096));
  cmd->add_option("--threads", args->threads, "Threads (0 = all cores)")->capture_default_str();
  cmd->callback([args] { RunSynth(*args); });
}

}  // namespace gonio::cli
