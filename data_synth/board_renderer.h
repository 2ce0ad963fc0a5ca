// Renders a board scene into a capture session folder (docs/formats.md): session.json,
// board.json, frame PNGs, camera.cameramodel and truth.json.
//
// Each pixel integrates the radiance over its footprint (box filter over the pixel square):
// the footprint's four corners are traced to the board exactly, and a pixel whose footprint
// crosses a tag-bit, region or board edge is supersampled (S^2 points in a multi-jittered
// pattern, bilinear
// inside the footprint) for the fraction of each surface; the radiance of each surface is
// evaluated at the footprint centre. Tag corners therefore land where the projection puts
// them, to a small fraction of a pixel.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "data_synth/scene.h"

namespace gonio::synth {

struct BoardRenderResult {
  int frames = 0;
  int poses = 0;
  double seconds = 0;
  size_t supersampled_pixels = 0;          // footprints that crossed an edge, all frames
  std::vector<double> saturated_fraction;  // per frame
  std::string Report() const;
};

// InputError for an invalid scene; writes into out_dir (created if needed).
BoardRenderResult RenderBoardSession(const Scene& scene, const std::filesystem::path& out_dir,
                                     int threads = 0);

}  // namespace gonio::synth
