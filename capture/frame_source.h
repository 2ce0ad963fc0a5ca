// One interface for everything that delivers frames: V4L2 devices, libcamera cameras, image
// folders and video files. The capture loop (capture_loop.h) only sees this interface.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace gonio::capture {

struct CapturedFrame {
  cv::Mat image;             // CV_8UC1, CV_16UC1, CV_8UC3 or CV_16UC3 (BGR)
  double exposure_s = 0.0;   // as the device reports it for this frame (not as requested)
  double gain = 1.0;         // unit: FrameSource::GainUnit()
  double timestamp_s = 0.0;  // device clock (monotonic), seconds; only differences matter
  uint64_t sequence = 0;     // device frame counter
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  // Stable identifier recorded as the session's camera_id, e.g. "v4l2:/dev/video0:HD Webcam".
  virtual std::string Id() const = 0;
  // One of Session::kGain* (common/session.h).
  virtual std::string GainUnit() const = 0;
  // Whether SetExposure can change anything (false for folders and video files, whose
  // exposures are fixed by the recording).
  virtual bool ControlsExposure() const = 0;

  // Manual exposure (auto exposure, auto gain and auto white balance off where the device has
  // them). gain unset: keep the current gain. The device rounds to what it supports; the
  // values actually used come back with each frame. InputError when outside the device range.
  virtual void SetExposure(double exposure_s, std::optional<double> gain) = 0;

  // Drops frames that may have been exposed before the last SetExposure or before a pause
  // (buffers queued in the driver), so the next Grab reflects the current settings.
  virtual void Settle() = 0;

  // The next frame. std::nullopt at the end of a folder or video file; InputError or a
  // runtime_error naming the device when it stops delivering.
  virtual std::optional<CapturedFrame> Grab() = 0;
};

}  // namespace gonio::capture
