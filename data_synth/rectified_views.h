// A textured scene rendered in MaterialGAN's rectified layout (docs/maps.md "Rectified
// captures"): every pose's view of the sample's largest centred square, resampled to N x N
// pixels of the square (as that system rectifies its phone photos), 8-bit with gamma 2.2,
// camera_pos.txt and light_pos.txt (cm, the sample's frame: z = 0 on the sample, centred at
// the square's centre, z towards the camera, y up the image) and image_size.txt (the side,
// cm); truth.json and the truth maps on the same N x N grid beside them.
#pragma once

#include <filesystem>

#include "data_synth/scene.h"

namespace gonio::synth {

struct RectifiedRenderResult {
  int views = 0;
  int size = 0;
  double side_m = 0;
  double exposure = 0;  // decoded value X per unit radiance (before noise)
  double seconds = 0;
};

// InputError for a scene without a texture or a point lamp, or size outside [16, 4096].
RectifiedRenderResult RenderRectifiedViews(const Scene& scene, int size,
                                           const std::filesystem::path& out_dir, int threads = 0);

}  // namespace gonio::synth
