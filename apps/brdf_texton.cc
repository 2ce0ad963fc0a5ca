// gonio brdf texton: the per-pit view and radiance histogram of the pitted-surface model
// (Koenderink et al. 1999, sec. 4.2) as a PNG plus the histogram as JSON.
#include <cmath>
#include <filesystem>

#include <opencv2/core.hpp>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/math.h"
#include "reflectance/pitted_texton.h"
#include "reflectance/registry.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

struct TextonArgs {
  std::string model = "pitted";
  std::vector<std::string> params;
  double theta_i_deg = NAN, theta_r_deg = NAN, phi_deg = 0.0;
  TextonOptions options;
  std::string out_png;
};

void RunTexton(const TextonArgs& args) {
  const ModelInfo& info = FindModel(args.model);
  const std::vector<double> params = ParseModelParams(info, args.params);
  double albedo = params[0], aperture = kHalfPi, coverage = 1.0;
  if (info.name == "pitted" || info.name == "pitted-exact") {
    aperture = params[1];
    coverage = params[2];
  } else if (info.name == "pitted-hemispherical") {
    coverage = params[1];
  } else {
    throw InputError(
        "brdf texton: --model must be pitted, pitted-exact or pitted-hemispherical, not " +
        info.name);
  }
  if (std::isnan(args.theta_i_deg) || std::isnan(args.theta_r_deg)) {
    throw InputError("brdf texton needs --theta-i and --theta-r (degrees)");
  }
  if (args.out_png.empty()) throw InputError("brdf texton needs --out PNG");
  if (fs::path(args.out_png).extension() != ".png") {
    throw InputError("brdf texton: --out " + args.out_png + " must end in .png");
  }
  args.options.Check();
  const Angles<double> a{DegToRad(args.theta_i_deg), DegToRad(args.theta_r_deg),
                         DegToRad(args.phi_deg)};
  const Texton t = RenderPittedTexton(albedo, aperture, a, args.options);

  // Paper fig. 13: the brightest pixel of each picture is white. 16-bit keeps the histogram's
  // resolution in the image.
  const double white = t.max_brdf > 0 ? t.max_brdf : 1.0;
  cv::Mat image(t.size, t.size, CV_16UC1);
  for (int row = 0; row < t.size; ++row) {
    for (int col = 0; col < t.size; ++col) {
      const double v = t.brdf[static_cast<size_t>(row) * t.size + col] / white;
      image.at<uint16_t>(row, col) = static_cast<uint16_t>(std::lround(65535.0 * v));
    }
  }
  WriteImage(args.out_png, image);

  // The model's own value for comparison: the pit alone (coverage 1) is what the pixels mean.
  std::vector<double> pit_only = params;
  pit_only.back() = 1.0;
  double model_brdf = 0.0, model_pit_brdf = 0.0;
  const std::string why = EvaluateChecked(info.name, params, a, &model_brdf);
  if (!why.empty()) throw InputError("model " + info.name + ": " + why);
  EvaluateChecked(info.name, pit_only, a, &model_pit_brdf);

  nlohmann::json j = {
      {"model", info.name},
      {"params", ParamsToJson(info, params)},
      {"theta_i_deg", args.theta_i_deg},
      {"theta_r_deg", args.theta_r_deg},
      {"phi_deg", args.phi_deg},
      {"png", args.out_png},
      {"size", t.size},
      {"pixel_value", "apparent BRDF N/(E0 cos theta_i) in 1/sr = gray/65535 * white_brdf"},
      {"white_brdf", white},
      {"pit_pixels", t.pit_pixels},
      {"pit_mean_brdf", t.pit_mean_brdf},
      {"model_brdf_pit_only", model_pit_brdf},
      {"model_brdf", model_brdf},
      {"coverage", coverage},
      {"flat_brdf", t.flat_brdf},
      {"histogram", {{"bin_edges", t.bin_edges}, {"counts", t.counts}}},
  };
  fs::path json_path = args.out_png;
  json_path.replace_extension(".json");
  WriteJsonAtomically(json_path, j);
  PrintJson(j);
}

}  // namespace

void AddBrdfTextonCommand(CLI::App& brdf) {
  auto args = std::make_shared<TextonArgs>();
  auto* cmd = brdf.add_subcommand(
      "texton", "Per-pit texton PNG and radiance histogram JSON of a pitted model");
  cmd->add_option("--model", args->model, "pitted, pitted-exact or pitted-hemispherical")
      ->capture_default_str();
  cmd->add_option("--param", args->params, "KEY=VALUE, registry units; repeatable");
  cmd->add_option("--theta-i", args->theta_i_deg, "Incidence polar angle, deg")->required();
  cmd->add_option("--theta-r", args->theta_r_deg, "Viewing polar angle, deg")->required();
  cmd->add_option("--phi", args->phi_deg, "Relative azimuth, deg (0 = backscatter side)")
      ->capture_default_str();
  cmd->add_option("--size", args->options.size, "Pixels per side")->capture_default_str();
  cmd->add_option("--bins", args->options.bins, "Histogram bins")->capture_default_str();
  cmd->add_option("--out", args->out_png, "Output PNG; the JSON goes next to it")->required();
  cmd->callback([args] { RunTexton(*args); });
}

}  // namespace gonio::cli
