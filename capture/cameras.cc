#include "capture/cameras.h"

#include <cmath>

#include <spdlog/spdlog.h>

#include "capture/libcamera_source.h"
#include "capture/v4l2_source.h"
#include "common/error.h"

namespace gonio::capture {

CaptureBackend ParseCaptureBackend(const std::string& word) {
  if (word == "v4l2") return CaptureBackend::kV4l2;
  if (word == "libcamera") return CaptureBackend::kLibcamera;
  throw InputError("--backend: '" + word + "' is not v4l2 or libcamera");
}

nlohmann::json ListCameras() {
  nlohmann::json devices = nlohmann::json::array();
  nlohmann::json skipped = nlohmann::json::array();
  for (const std::string& node : ListVideoNodes()) {
    try {
      const V4l2DeviceInfo info = QueryV4l2Device(node);
      if (info.is_capture) {
        devices.push_back(info.ToJson());
      } else {
        skipped.push_back({{"device", node}, {"reason", info.not_capture_reason}});
      }
    } catch (const InputError& e) {
      skipped.push_back({{"device", node}, {"reason", e.what()}});
    }
  }
  if (HaveLibcamera()) {
    try {
      for (const auto& camera : ListLibcameraCameras()) devices.push_back(camera);
    } catch (const InputError& e) {
      spdlog::warn("{}", e.what());
    }
  }
  return {{"devices", devices}, {"skipped", skipped}, {"libcamera", HaveLibcamera()}};
}

// The buffer count is each backend's to check (v4l2 2..32, libcamera 1..32).
void CameraRequest::Check() const {
  if (device.empty()) throw InputError("--device: give the camera");
  if (!(longest_exposure_s >= 0 && std::isfinite(longest_exposure_s))) {
    throw InputError("--exposures: the longest exposure must be a finite value >= 0");
  }
}

std::unique_ptr<FrameSource> OpenCamera(const CameraRequest& request) {
  request.Check();
  if (request.backend == CaptureBackend::kV4l2) {
    V4l2Source::Options o;
    o.device = request.device;
    o.format = request.format;
    o.buffers = request.buffers;
    o.longest_exposure_s = request.longest_exposure_s;
    return std::make_unique<V4l2Source>(o);
  }
  LibcameraSource::Options o;
  o.camera = request.device;
  o.format = request.format;
  o.buffers = request.buffers;
  return std::make_unique<LibcameraSource>(o);
}

}  // namespace gonio::capture
