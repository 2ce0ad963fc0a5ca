// The lamp from the white reference alone (white_lamp.h).
#include "estimation/joint/white_lamp.h"

#include <algorithm>
#include <set>

namespace gonio {

std::optional<JointFitResult> FitWhiteReferenceLamp(const ObservationSet& data,
                                                    const JointFitOptions& options) {
  ObservationSet white;
  white.channels = data.channels;
  white.frame_files = data.frame_files;
  std::set<int> frames;
  for (const Observation& o : data.observations) {
    if (!o.white) continue;
    white.observations.push_back(o);
    white.observations.back().white = false;  // the paper is the sample of this fit
    frames.insert(o.frame);
  }
  if (white.observations.size() < kMinWhiteObservations || frames.size() < 3) return std::nullopt;
  // An even subsample, as the joint fit's final fit takes.
  const size_t stride =
      std::max<size_t>(1, white.observations.size() / options.final_max_observations);
  if (stride > 1) {
    std::vector<Observation> kept;
    for (size_t i = 0; i < white.observations.size(); i += stride) {
      kept.push_back(white.observations[i]);
    }
    white.observations = std::move(kept);
  }
  JointFitOptions o = options;
  o.white_albedo.reset();                 // A_w I is one scale: the paper's albedo is not needed
  o.sample_height = NuisanceTerm::kNone;  // the paper lies on the board
  o.ambient = options.ambient == AmbientTerm::kFit ? AmbientTerm::kFit : AmbientTerm::kNone;
  o.criterion = Criterion::kBic;  // one model: no held-out refits
  JointFitResult fit = FitJoint("lambert", white, InitialLamp(white, o), o);
  if (!fit.material.converged) return std::nullopt;
  return fit;
}

}  // namespace gonio
