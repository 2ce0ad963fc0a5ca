// BRDF observations back-projected from photographs: each is a sample (or white-reference)
// point on the board with the camera centre it was seen from and its linear radiance.
// Angles are not stored: they depend on the lamp position, which the joint fit estimates.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace gonio {

struct Observation {
  int frame = 0;
  double px = 0, py = 0;  // pixel (patch centre), pixel-centre convention
  // Zero until set: a copy of an Observation a caller filled in part (the synthetic ones leave
  // the rotation out) must not read uninitialised memory. p_in_board is the point on the
  // board (z = 0; a raised sample: z = -height), m.
  Eigen::Vector3d p_in_board = Eigen::Vector3d::Zero();
  Eigen::Vector3d camera_in_board = Eigen::Vector3d::Zero();
  Eigen::Vector3d board_from_cam_aa = Eigen::Vector3d::Zero();  // angle-axis of board_from_cam
  bool white = false;  // white reference paper (known albedo) instead of the sample
  int num_pixels = 1;
  // Second moment of the patch's area about p_in_board, board x and y (m^2): the radiance is
  // the mean over that area, which the joint fit models where the BRDF bends across it
  // (docs/pipeline.md "Patch average"). Zero for one pixel and for files without it.
  Eigen::Matrix2d patch_moment = Eigen::Matrix2d::Zero();
  std::vector<double> radiance;  // per channel, linear relative units
  std::vector<double> variance;  // per channel
  // Per channel: the mean raw pixel value the radiance was read from (extraction only; empty
  // when read from observations.csv). The response's error depends on it
  // (estimation/joint/calibration_error.h).
  std::vector<double> value;
};

struct ObservationSet {
  int channels = 1;
  std::vector<std::string> frame_files;  // frame index -> image file (for reports)
  std::vector<Observation> observations;
  // Counts of pixels left out, by reason (saturated, dark, tag, outside).
  std::vector<std::pair<std::string, size_t>> excluded;
  // Frames whose lamp-off partner's radiance was subtracted (the room's light removed).
  size_t lamp_off_frames = 0;
  // What the extraction assumed (e.g. a linear camera, `--assume-linear`), one sentence each:
  // written as "# assumption: ..." lines, so a later `gonio fit` reports them too.
  std::vector<std::string> assumptions;
};

// observations.csv (docs/formats.md). InputError naming the file and line on bad content.
void WriteObservations(const std::filesystem::path& path, const ObservationSet& set);
ObservationSet ReadObservations(const std::filesystem::path& path);
// Every observation's raw pixel value in every channel (Observation::value), one list: where
// the data sit on the response's value range.
std::vector<double> RawValuesOf(const ObservationSet& set);
// Several files into one set; frame indices are offset so frames stay distinct.
ObservationSet MergeObservations(const std::vector<ObservationSet>& sets);

}  // namespace gonio
