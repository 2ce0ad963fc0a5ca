// gonio photometric: inverse response from an exposure sweep (and, with the board, vignetting).
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "apps/cli_util.h"
#include "apps/commands.h"
#include "calib/response.h"
#include "common/error.h"
#include "common/io.h"
#include "common/plot.h"

namespace fs = std::filesystem;

namespace gonio::cli {
namespace {

struct ResponseArgs {
  std::string sweep, list, out, plot;
  double black_level = -1;
  int bit_depth = 0;
  bool drop_inconsistent = false, compare_debevec = true;
  double tolerance = 0.05;
};

void PlotResponse(const ResponseResult& r, const std::string& png) {
  PlotSpec spec;
  spec.title = fmt::format("inverse response ({} bit), linearity error {:.2f}%", r.bit_depth,
                           100 * r.median_ratio_error);
  spec.xlabel = "pixel value";
  spec.ylabel = "relative exposure (log)";
  spec.log_y = true;
  const char* names[] = {"B", "G", "R"};
  for (int c = 0; c < r.channels; ++c) {
    PlotSeries s;
    s.label = r.channels == 3 ? names[c] : "grey";
    for (size_t z = 0; z < r.inverse_response[c].size(); ++z) {
      if (r.inverse_response[c][z] <= 0) continue;
      s.x.push_back(z);
      s.y.push_back(r.inverse_response[c][z]);
    }
    spec.series.push_back(std::move(s));
  }
  RenderPlot(spec, png);
}

void RunResponse(const ResponseArgs& args) {
  std::string list =
      args.list.empty() ? (fs::path(args.sweep) / "image_list.txt").string() : args.list;
  const auto frames = LoadExposureSweep(args.sweep, list);
  ResponseOptions o;
  o.bit_depth = args.bit_depth;
  if (args.black_level >= 0) o.black_level = args.black_level;
  o.drop_inconsistent = args.drop_inconsistent;
  o.exposure_tolerance = args.tolerance;
  spdlog::info("calibrating the inverse response from {} frames", frames.size());
  const ResponseResult r = CalibrateResponse(frames, o);
  nlohmann::json j = r.ToJson();
  j["sweep"] = args.sweep;
  j["list"] = list;
  if (args.compare_debevec && frames[0].image.depth() == CV_8U) {
    // OpenCV's Debevec calibration on the same frames, with the listed times and with ours.
    std::vector<double> listed, ours;
    std::vector<bool> used;
    for (size_t k = 0; k < frames.size(); ++k) {
      listed.push_back(frames[k].exposure_s);
      ours.push_back(r.frames[k].estimated_s);
      used.push_back(r.frames[k].used);
    }
    const auto deb_listed = DebevecInverseResponse(frames, listed);
    const auto deb_ours = DebevecInverseResponse(frames, ours);
    const std::vector<bool> all(frames.size(), true);
    const double err_listed =
        MedianRatioError(frames, listed, all, deb_listed, r.saturation_level, r.black_level, 8);
    const double err_ours =
        MedianRatioError(frames, ours, used, deb_ours, r.saturation_level, r.black_level, 8);
    j["debevec_baseline"] = {{"worst_pair_error_listed_times", err_listed},
                             {"worst_pair_error_gonio_times", err_ours}};
    std::cout << fmt::format(
        "OpenCV Debevec: worst-pair ratio error {:.2f}% with the listed times, {:.2f}% given "
        "gonio's frames and times (gonio: {:.2f}%)\n",
        100 * err_listed, 100 * err_ours, 100 * r.median_ratio_error);
  }
  const std::string plot =
      args.plot.empty() ? (fs::path(args.out).replace_extension(".png")).string() : args.plot;
  PlotResponse(r, plot);
  j["plot"] = plot;
  WriteJsonAtomically(args.out, j);
  std::cout << r.Report();
}

}  // namespace

void AddPhotometricCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("photometric", "Photometric calibration: response, vignetting");
  cmd->require_subcommand(1);
  auto args = std::make_shared<ResponseArgs>();
  auto* resp = cmd->add_subcommand("response", "Inverse response from an exposure sweep");
  resp->add_option("--sweep", args->sweep, "Folder with the sweep's images")->required();
  resp->add_option("--list", args->list, "List 'file exposure_s' (default SWEEP/image_list.txt)");
  resp->add_option("--out", args->out, "response.json")->required();
  resp->add_option("--plot", args->plot, "PNG of the curve (default: OUT with .png)");
  resp->add_option("--black-level", args->black_level,
                   "Black level in pixel values (default: estimate)");
  resp->add_option("--bit-depth", args->bit_depth, "Bits per value (default: from the images)");
  resp->add_option("--exposure-tolerance", args->tolerance,
                   "Relative mismatch that marks a listed exposure as wrong")
      ->capture_default_str();
  resp->add_flag("--drop-inconsistent", args->drop_inconsistent,
                 "Leave out frames whose brightness contradicts their listed exposure "
                 "(default: re-time them)");
  resp->callback([args] { RunResponse(*args); });
}

}  // namespace gonio::cli
