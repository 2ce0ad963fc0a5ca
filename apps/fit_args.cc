#include "apps/fit_args.h"

#include "apps/cli_util.h"
#include "common/error.h"

namespace gonio::cli {

void AddFitArgs(CLI::App* cmd, FitArgs* a) {
  cmd->add_option("--models", a->models,
                  "auto (staged search), all (every candidate), or a comma-separated list")
      ->capture_default_str();
  cmd->add_option("--criterion", a->criterion, "bic, aic or cv")->capture_default_str();
  cmd->add_option("--lamp-frame,--light-frame", a->lamp_frame,
                  "board (camera moves) or camera (board moves)")
      ->capture_default_str();
  cmd->add_option("--lamp-init,--light-init", a->lamp_init,
                  "X,Y,Z start in the lamp frame, metres");
  cmd->add_option("--white-albedo", a->white_albedo, "Known albedo of the white reference");
  cmd->add_flag("--grey", a->grey, "One albedo for all channels");
  cmd->add_option("--noise-floor", a->noise_floor,
                  "Relative calibration uncertainty in each radiance, e.g. 0.01 (default: "
                  "photometric.json's relative_accuracy for run, else 0.01)");
  cmd->add_option("--sample-height", a->sample_height,
                  "A correction to board.json's sample_height_m: none, fit, or auto (fitted "
                  "when the criterion says the data need it); docs/pipeline.md")
      ->capture_default_str();
  cmd->add_flag("--fit-sample-height", a->fit_sample_height, "The same as --sample-height fit");
  cmd->add_option("--robust", a->robust, "none, huber or cauchy")->capture_default_str();
  cmd->add_option("--ambient", a->ambient,
                  "The room's light when the session has no lamp-off frames: none, fit (a "
                  "constant per channel on the sample and on the white reference) or auto "
                  "(fitted when the criterion says the data need it; lamp-off frames are "
                  "better); docs/pipeline.md")
      ->capture_default_str();
  cmd->add_option("--patch-model", a->patch_model,
                  "A patch's radiance as the BRDF at its centre (centre), its mean over the "
                  "patch (average), or auto (the mean where the centre's bias could move a "
                  "parameter by a fifth of its sd); docs/pipeline.md")
      ->capture_default_str();
  cmd->add_option("--threads", a->threads, "Threads (0 = all cores)");
}

JointFitOptions ToJointFitOptions(const FitArgs& a) {
  JointFitOptions o;
  o.exhaustive = a.models == "all";
  if (a.models != "auto" && a.models != "all") o.candidates = SplitComma(a.models);
  if (a.models != "auto" && a.models != "all" && o.candidates.empty()) {
    throw InputError("--models: empty list (give auto or comma-separated model names)");
  }
  o.criterion = ParseCriterion(a.criterion, "--criterion");
  o.lamp_frame = ParseLampFrame(a.lamp_frame, "--lamp-frame");
  if (!a.lamp_init.empty()) o.lamp_init = ParseVector3(a.lamp_init, "--lamp-init");
  if (!a.white_albedo.empty()) {
    const double w = ParseNumber(a.white_albedo, "--white-albedo");
    if (!(w > 0 && w <= 1)) {
      throw InputError("--white-albedo: " + a.white_albedo + " is not an albedo in (0, 1]");
    }
    o.white_albedo = w;
  }
  if (!a.noise_floor.empty()) {
    const double f = ParseNumber(a.noise_floor, "--noise-floor");
    if (!(f >= 0 && f < 1)) {
      throw InputError("--noise-floor: " + a.noise_floor + " is not a fraction in [0, 1)");
    }
    o.relative_noise_floor = f;
  }
  o.per_channel = !a.grey;
  o.sample_height = ParseNuisanceTerm(a.sample_height, "--sample-height");
  if (a.fit_sample_height) {
    if (a.sample_height != "auto" && a.sample_height != "fit") {
      throw InputError("--fit-sample-height contradicts --sample-height " + a.sample_height);
    }
    o.sample_height = NuisanceTerm::kFit;
  }
  o.robust_loss = ParseRobustLoss(a.robust, "--robust");
  o.ambient = ParseAmbientTerm(a.ambient, "--ambient");
  o.patch_model = ParsePatchModel(a.patch_model, "--patch-model");
  o.threads = a.threads;
  o.Check();
  return o;
}

}  // namespace gonio::cli
