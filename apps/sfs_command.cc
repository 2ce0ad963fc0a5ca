// gonio sfs: perspective shape-from-shading of one masked object with a fitted rough BRDF as
// the reflectance prior, or a Lambertian one for comparison (docs/sfs.md).
#include <filesystem>
#include <memory>
#include <optional>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/log.h"
#include "estimation/sfs/sfs.h"
#include "estimation/sfs/sfs_io.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

struct SfsArgs {
  std::string init_depth, input, image, camera, lamp, material, mask, out;
  double distance = 0;
  bool compare_lambert = false;
  SfsOptions options;
};

void RunSfs(const SfsArgs& args) {
  if (args.out.empty()) throw InputError("sfs: --out DIR is required");
  args.options.Check();
  // OUT is written as a whole, replacing only a previous sfs output (its sfs.json).
  FolderTransaction::CheckTarget(args.out, "sfs.json");
  SfsInputPaths paths;
  paths.image = args.image;
  paths.camera = args.camera;
  paths.material = args.material;
  paths.mask = args.mask;
  paths.lamp = args.lamp;
  paths.distance = args.distance;
  if (!args.input.empty()) paths.FillFromFolder(args.input);
  SfsInput input = LoadSfsInput(paths, args.options.reflectance);
  if (!args.init_depth.empty()) {
    ImageExpectation expect;
    expect.pixels = ImageExpectation::Pixels::kAny;
    expect.channels = 1;
    expect.channels_of = "a depth map (--init-depth)";
    expect.size = input.problem.radiance.size();
    expect.size_of = "the image " + input.image_path;
    ReadImage(args.init_depth, expect).convertTo(input.problem.initial_depth, CV_64F);
  }
  const SfsResult result = SolveSfs(input.problem, args.options);
  spdlog::info("{}", result.Report());
  const auto truth = CompareWithTruth(paths.truth_dir, input, result);
  std::optional<SfsLambertComparison> comparison;
  std::optional<SfsInput> lambert_input;
  if (args.compare_lambert && args.options.reflectance == "material") {
    lambert_input = input;
    lambert_input->problem.absolute = false;  // k is the Lambertian albedo, from the image
    SfsOptions lambert_options = args.options;
    lambert_options.reflectance = "lambert";
    comparison.emplace();
    comparison->lambert = SolveSfs(lambert_input->problem, lambert_options);
    spdlog::info("{}", comparison->lambert.Report());
    comparison->truth = CompareWithTruth(paths.truth_dir, *lambert_input, comparison->lambert);
  }
  FolderTransaction folder(args.out, "sfs.json");
  if (comparison) {
    WriteSfsOutputs(folder.tmp() / "lambert", *lambert_input, comparison->lambert,
                    comparison->truth);
  }
  nlohmann::json j =
      WriteSfsOutputs(folder.tmp(), input, result, truth, comparison ? &*comparison : nullptr);
  folder.Commit();
  j.erase("provenance");
  j["out"] = args.out;
  PrintJson(j);
}

}  // namespace

void AddSfsCommand(CLI::App& app) {
  auto args = std::make_shared<SfsArgs>();
  auto* cmd = app.add_subcommand(
      "sfs", "Shape from shading of a masked object under a point lamp with a fitted BRDF");
  cmd->add_option("--input", args->input,
                  "Folder written by gonio synth --preset sfs-*: defaults for every file");
  cmd->add_option("--image", args->image, "Linear image (8/16-bit PNG or TIFF)");
  cmd->add_option("--camera", args->camera, "camera.cameramodel (mrcal)");
  cmd->add_option("--lamp,--light", args->lamp,
                  "Lamp position X,Y,Z in the camera frame (m) or 'collocated'");
  cmd->add_option("--material", args->material, "fit.json (selected model and parameters)");
  cmd->add_option("--mask", args->mask, "Object mask (8-bit, >127 = object)");
  cmd->add_option("--out", args->out, "Output folder");
  cmd->add_option("--reflectance", args->options.reflectance, "material or lambert")
      ->capture_default_str();
  cmd->add_option("--distance", args->distance,
                  "Depth of the brightest object pixel (m); default from absolute radiometry");
  cmd->add_flag("--compare-lambert", args->compare_lambert,
                "Also solve with a Lambertian prior (OUT/lambert/) and plot both recovered "
                "shapes (comparison_depth.png; Oren-Nayar figs. 22-23)");
  cmd->add_option("--init-depth", args->init_depth,
                  "Initial depth map (float TIFF, metres) instead of the mask balloon");
  cmd->add_option("--smoothness", args->options.smoothness,
                  "Log-depth second-difference weight (noise-free; grows with the noise)")
      ->capture_default_str();
  cmd->add_option("--noise", args->options.noise_relative,
                  "Image noise (std / median radiance) for the smoothness weight; < 0: "
                  "estimated from the image")
      ->capture_default_str();
  cmd->add_option("--contour-weight", args->options.contour_weight, "Occluding-contour weight")
      ->capture_default_str();
  cmd->add_option("--levels", args->options.levels, "Pyramid levels (0 = auto)")
      ->capture_default_str();
  cmd->add_option("--max-iterations", args->options.max_iterations, "Per coarse pyramid level")
      ->capture_default_str();
  cmd->add_option("--max-iterations-finest", args->options.max_iterations_finest,
                  "At full resolution")
      ->capture_default_str();
  cmd->add_option("--finest-solver", args->options.finest_solver,
                  "Linear solver at full resolution: cholesky (exact steps) or cg (faster, "
                  "after a coarser level)")
      ->capture_default_str();
  cmd->add_option("--cg-iterations", args->options.cg_iterations,
                  "Conjugate-gradient iterations per step of the cg solver")
      ->capture_default_str();
  cmd->add_option("--threads", args->options.threads, "Threads (0 = all cores)")
      ->capture_default_str();
  cmd->callback([args] { RunSfs(*args); });
}

}  // namespace gonio::cli
