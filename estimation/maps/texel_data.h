// The observations of a textured sample on a texel grid (docs/maps.md "Method"): every texel
// of the sample region, seen in every view where it projects onto valid pixels, with its
// linear radiance per channel (cubic convolution of the 4 x 4 pixels around its projection) and
// the two parts of its noise the maps' noise model scales: the calibration's propagated pixel
// variance and a shot-noise basis proportional to the signal.
//
// Maps are RGB: a colour frame, which OpenCV decodes as B, G, R, is reordered on sampling.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/geometry/board.h"
#include "calib/photometry/photometric.h"
#include "common/camera_model.h"
#include "common/geometry.h"

namespace cv {
class Mat;
}

namespace gonio {

// Square texels over an axis-aligned rectangle of the sample plane (board frame). Texel (i, j)
// (column i, row j) has its centre at origin + (i, j) * texel on z = plane_z: map rows run
// along board +y, which is down the map as the board is seen from the front.
struct TexelGrid {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // centre of texel (0, 0), metres
  double texel = 0;                                  // metres
  int width = 0, height = 0;
  double plane_z = 0;  // the sample's top: -board.sample_height()

  size_t size() const { return static_cast<size_t>(width) * height; }
  Eigen::Vector3d Centre(size_t index) const {
    return {origin.x() + static_cast<double>(index % width) * texel,
            origin.y() + static_cast<double>(index / width) * texel, plane_z};
  }
};

// The grid over the bounding box of `region` (a polygon, board frame) with texels of `texel`
// metres; `mask` (per texel) is 1 where the texel's centre lies inside the polygon by more than
// `margin` metres.
TexelGrid GridOver(const std::vector<Eigen::Vector2d>& region, double texel, double plane_z,
                   double margin, std::vector<uint8_t>* mask);

// Where a view was taken from (board frame).
struct TexelView {
  std::string name;  // the frame's file, or NN.png
  Eigen::Vector3d camera_in_board = Eigen::Vector3d::Zero();
  Rigid3d board_from_cam;                                   // a lamp fixed to the camera moves
  Eigen::Vector3d lamp_in_board = Eigen::Vector3d::Zero();  // set from the lamp before a solve
  // The interpolation's support in this view as an angle (edge_margin_px over the focal
  // length): TexelData::SampleReach stretches it by the view's obliquity. 0: none beyond the
  // data's reach_m (a rectified view).
  double support_rad = 0;
};

// One view's samples, texel-major: value[texel * channels + c].
struct ViewSamples {
  std::vector<float> radiance, var_read, var_shot;
  std::vector<uint8_t> valid;  // per texel
  size_t count = 0;            // valid texels
};

// A sample of the white reference (known albedo, Lambertian, the printed plane z = 0): what
// fixes the lamp's intensity and helps place it.
struct WhiteSample {
  int view = 0;
  Eigen::Vector3d p_in_board = Eigen::Vector3d::Zero();
  std::array<float, 3> radiance{}, var_read{}, var_shot{};
};

struct TexelData {
  TexelGrid grid;
  std::vector<uint8_t> mask;  // per texel: inside the sample region
  int channels = 3;
  std::vector<TexelView> views;
  std::vector<ViewSamples> samples;  // per view
  std::vector<WhiteSample> white;
  // How far from a texel's centre its samples reach on the sample at least (the
  // interpolation's support in pixels at the median view and half a texel): the region's
  // margin, so that no texel mixes sample and paper.
  double reach_m = 0;
  size_t masked_texels() const;
  // Marks invalid every sample with a non-finite or negative-variance channel (radiance,
  // read or shot variance), and drops such white samples; returns how many. No input gonio
  // reads yields one, but the solver's sums would carry it into every map (SolveMaps calls
  // it first).
  size_t InvalidateNonFinite();
  // How far on the sample view v's sample of the point p reaches (metres) towards the unit
  // in-plane direction `towards`: the interpolation's support projected on the sample, an
  // ellipse whose half-width support_rad D across the view's tilt is stretched along it by
  // 1 / cos(view angle), plus half a texel; at least reach_m. A sample nearer than this to
  // another material or the region's edge in that direction mixes what lies beyond
  // (docs/maps.md "Material edges"): at 62 deg, towards the view, twice the head-on reach.
  double SampleReach(size_t v, const Eigen::Vector3d& p, const Eigen::Vector2d& towards) const;
  // The same in the direction it reaches farthest (along the view's tilt).
  double SampleReach(size_t v, const Eigen::Vector3d& p) const;
};

struct TexelSamplingOptions {
  double texel_m = 0;  // 0: the median pixel footprint at the sample's centre over the views
  // Region edges eroded by this many pixel footprints, so no texel mixes sample and paper.
  double edge_margin_px = 2.0;
  double white_spacing_m = 0.002;  // white-reference samples on a grid this far apart
  double max_view_angle_deg = 80;  // texels seen more obliquely are left out
  int threads = 0;
  void Check() const;  // InputError naming the option
};

// Frames into TexelData one decoded frame at a time (the caller reads them). Usage: construct
// with every located frame's pose (the texel size is chosen from them), AddFrame for each, then
// Finish.
class TexelSampler {
 public:
  struct Pose {
    std::string file;
    Rigid3d cam_from_board;
    double exposure_s = 1, gain = 1;
  };
  TexelSampler(const CameraModel& camera, const Board& board,
               const PhotometricCalibration& photometric, const std::vector<Pose>& poses,
               const TexelSamplingOptions& options);
  // raw: the frame of poses[k] as decoded (cv::IMREAD_UNCHANGED). InputError naming `what`
  // when its size or channel count does not match the camera and the calibration.
  // displacement: where each texel is really seen, P + displacement(P) (the view's
  // registration, estimation/maps/registration.h); null: at P.
  void AddFrame(
      size_t k, const cv::Mat& raw, const std::string& what,
      const std::function<Eigen::Vector2d(const Eigen::Vector3d&)>* displacement = nullptr);
  // InputError naming `what` when no texel was seen in any frame.
  TexelData Finish(const std::string& what);
  const TexelGrid& grid() const { return data_.grid; }

 private:
  const CameraModel& camera_;
  const PhotometricCalibration& photometric_;
  std::vector<Pose> poses_;
  TexelSamplingOptions options_;
  TexelData data_;
  TexelGrid white_grid_;
  std::vector<uint8_t> white_mask_;
  // Per texel of the grid and of the white grid: how far inside its region its centre lies
  // (metres) and the unit direction to the nearest point of the region's edge. A view's sample
  // that reaches the edge (TexelData::SampleReach) mixes what lies beyond: not taken.
  struct Inside {
    float distance_m = 0;
    Eigen::Vector2f towards_edge = Eigen::Vector2f::Zero();
  };
  std::vector<Inside> inside_, white_inside_;
  static std::vector<Inside> InsideOf(const std::vector<Eigen::Vector2d>& region,
                                      const TexelGrid& grid);
  bool Clear(const Inside& in, size_t view, const Eigen::Vector3d& p) const;
};

}  // namespace gonio
