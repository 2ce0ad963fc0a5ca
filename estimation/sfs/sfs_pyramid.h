// The image pyramid of gonio sfs (estimation/sfs/sfs.h), internal to sfs.cc: levels of
// block-averaged radiance and mask, normals from a log-depth map, the convex initial surface
// and upsampling between levels.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "estimation/sfs/sfs.h"

namespace gonio::sfs_internal {

// One pyramid level: radiance averaged over 2^L x 2^L blocks wholly inside the mask.
struct Level {
  int scale = 1, w = 0, h = 0;
  cv::Mat radiance, mask;             // CV_64F, CV_8U
  std::vector<Eigen::Vector3d> rays;  // per pixel, (x, y, 1)
  bool In(int x, int y) const {
    return x >= 0 && y >= 0 && x < w && y < h && mask.at<uint8_t>(y, x);
  }
  const Eigen::Vector3d& Ray(int x, int y) const { return rays[static_cast<size_t>(y) * w + x]; }
};

// The level of block size `scale` (a power of two; 1 is the full-resolution image).
Level MakeLevel(const SfsProblem& pr, int scale);

// A mask pixel whose four neighbours are in the mask (where the photometric residual applies).
bool Interior(const Level& lv, int x, int y);

// Normal at a mask pixel from the log-depth map u: central differences, one-sided where a
// neighbour is outside the mask. False when a direction has no neighbour at all.
bool NormalAt(const Level& lv, const cv::Mat& u, int x, int y, Eigen::Vector3d* n);

// Convex initial log-depth from the mask's distance transform, the anchor pixel (ax, ay) at
// depth `anchor` (metres); f_px is the focal length in full-resolution pixels.
cv::Mat BalloonLogDepth(const Level& lv, double f_px, double anchor, int ax, int ay);

// u of level `coarse` bilinearly upsampled to level `fine` (extended outside the coarse mask
// first, so pixels near the contour have values on both sides).
cv::Mat Upsample(const Level& coarse, cv::Mat u, const Level& fine);

}  // namespace gonio::sfs_internal
