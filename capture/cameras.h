// The cameras this machine has, and opening one by backend (gonio capture --list-devices,
// --device).
#pragma once

#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "capture/frame_source.h"
#include "capture/pixel_format.h"

namespace gonio::capture {

enum class CaptureBackend { kV4l2, kLibcamera };

// "v4l2" or "libcamera"; InputError naming --backend otherwise.
CaptureBackend ParseCaptureBackend(const std::string& word);

// {"devices": [...], "skipped": [{"device", "reason"}], "libcamera": bool}: every V4L2 capture
// node (the other nodes skipped with the reason) and every camera libcamera sees.
nlohmann::json ListCameras();

struct CameraRequest {
  CaptureBackend backend = CaptureBackend::kV4l2;
  std::string device;  // /dev/videoN (v4l2); libcamera id, index or /dev/videoN (libcamera)
  FormatRequest format;
  int buffers = 4;                  // streaming buffers in the ring
  double longest_exposure_s = 0.0;  // v4l2: the frame period must allow it
  void Check() const;               // InputError naming the option
};

std::unique_ptr<FrameSource> OpenCamera(const CameraRequest& request);

}  // namespace gonio::capture
