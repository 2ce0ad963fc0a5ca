// HDR merge of an exposure bracket (frames of one pose at several exposures): each frame is
// turned into radiance with its variance (PhotometricCalibration::ToRadiance) and the frames are
// averaged per pixel and channel with inverse-variance weights, the minimum-variance unbiased
// combination of independent estimates of the same radiance. Saturated and dark pixels of a
// frame carry no weight; a pixel no frame reads validly gets the bound its frames give (the
// shortest exposure's value where all saturate, the longest's where all are dark) and is marked
// invalid, so no NaN is ever written.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/photometry/photometric.h"

namespace gonio {

struct HdrFrame {
  std::string file;
  cv::Mat raw;
  double exposure_s = 0;
  double gain = 1;
};

struct HdrResult {
  cv::Mat radiance;  // CV_32FC(channels)
  cv::Mat variance;  // same
  cv::Mat valid;     // CV_8U, 255 where at least one frame reads the pixel validly
  cv::Mat count;     // CV_8U, number of frames that contributed
  double valid_fraction = 0;
  // Fraction of pixels valid in the merge but not in the longest exposure alone.
  double extended_fraction = 0;
  std::string Report() const;
};

// InputError when the frames are empty or differ in size or channels.
HdrResult MergeBracket(const PhotometricCalibration& calibration,
                       const std::vector<HdrFrame>& frames);

}  // namespace gonio
