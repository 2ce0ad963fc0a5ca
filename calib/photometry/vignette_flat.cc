// Vignetting from a flat field without poses (calib/photometry/vignette.h,
// CalibrateFlatFieldVignette): every sampled pixel of frame k is one sample of texture cell k, so
// the shared solver (vignette_internal.h) fits I_k(x) = V(x) C_k.
#include <algorithm>
#include <mutex>

#include <fmt/format.h>

#include "calib/photometry/vignette.h"
#include "calib/photometry/vignette_internal.h"
#include "common/error.h"
#include "common/log.h"
#include "common/parallel.h"

namespace gonio {

using namespace vignette_internal;

namespace {

// The valid sampled pixels of one frame (not saturated, not dark), channels averaged.
std::vector<Sample> FlatFieldSamples(const VignetteFrame& f, int frame,
                                     const PhotometricCalibration& linear, const PixelGrid& grid) {
  cv::Mat radiance, variance, valid;
  linear.ToRadiance(f.image, f.exposure_s, f.gain, &radiance, &variance, &valid);
  const int ch = radiance.channels();
  std::vector<Sample> out;
  for (size_t i = 0; i < grid.pixels.size(); ++i) {
    const cv::Point& xy = grid.xy[i];
    if (!valid.at<uint8_t>(xy)) continue;
    const float* v = radiance.ptr<float>(xy.y) + xy.x * ch;
    double sum = 0;
    for (int c = 0; c < ch; ++c) sum += v[c];
    out.push_back({static_cast<int32_t>(i), frame, static_cast<float>(sum / ch), 0.0f,
                   MeanRawAt(f.image, xy)});
  }
  return out;
}

// Split halves of a flat field (vignette_accuracy.cc): alternate frames with usable pixels,
// each frame its own texture cell, renumbered within its half.
void MeasureFlatFieldError(const CameraModel& camera, const PixelGrid& grid,
                           const std::vector<std::vector<Sample>>& per_frame,
                           const VignetteOptions& options, VignetteResult* result) {
  std::array<SampleSet, 2> halves;
  for (auto& h : halves) h.cell_count.assign(grid.gw * grid.gh, 0);
  for (const auto& v : per_frame) {
    if (v.empty()) continue;
    SampleSet& h = halves[(halves[0].texture_cells + halves[1].texture_cells) % 2];
    for (Sample s : v) {
      s.acell = static_cast<int32_t>(h.texture_cells);
      h.samples.push_back(s);
      ++h.cell_count[grid.pixels[s.ray].vcell];
    }
    ++h.texture_cells;
  }
  if (halves[1].texture_cells == 0) {
    result->map_error_note = "split halves: one flat-field frame with usable pixels";
    return;
  }
  MeasureMapError(camera, grid, std::move(halves), options, result);
}

}  // namespace

VignetteResult CalibrateFlatFieldVignette(const CameraModel& camera,
                                          const PhotometricCalibration& response_only,
                                          const std::vector<VignetteFrame>& frames,
                                          const VignetteOptions& options) {
  options.Check();
  if (frames.empty()) throw InputError("vignetting from a flat field needs at least one frame");
  for (const auto& f : frames) {
    if (f.image.cols != camera.width || f.image.rows != camera.height) {
      throw InputError(fmt::format("{}: image is {}x{}, the camera model {}x{}", f.file,
                                   f.image.cols, f.image.rows, camera.width, camera.height));
    }
  }
  PhotometricCalibration linear = response_only;
  linear.vignette = cv::Mat();
  const PixelGrid grid = SamplePixelRays(camera, options);
  std::vector<std::vector<Sample>> per_frame(frames.size());
  Progress progress("vignetting: reading flat-field frames", frames.size());
  std::mutex progress_mutex;
  ParallelFor(frames.size(), options.threads, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      per_frame[k] = FlatFieldSamples(frames[k], static_cast<int>(k), linear, grid);
      std::lock_guard<std::mutex> lock(progress_mutex);
      progress.Step();
    }
  });
  progress.Done();
  VignetteResult result;
  SampleSet set;
  set.texture_cells = frames.size();
  set.cell_count.assign(grid.gw * grid.gh, 0);
  for (const auto& v : per_frame) {
    result.frames_used += !v.empty();
    for (const Sample& s : v) {
      set.samples.push_back(s);
      ++set.cell_count[grid.pixels[s.ray].vcell];
    }
  }
  if (set.samples.empty()) {
    throw InputError("no usable pixel in any flat-field frame (all saturated or dark?)");
  }
  result.poses = 0;  // not known: no poses
  result.lamp_test.run = false;
  SolveVignette(camera, grid, std::move(set), options, false, true, &result);
  MeasureFlatFieldError(camera, grid, per_frame, options, &result);
  return result;
}

}  // namespace gonio
