// libcamera cameras (embedded camera modules, and UVC webcams through libcamera's uvcvideo
// pipeline): camera manager, stream configuration, ExposureTime/AnalogueGain controls, and the
// exposure and gain the sensor really used, read from each completed request's metadata.
// Built only when libcamera is found (GONIO_HAVE_LIBCAMERA); otherwise every entry point says
// so with an InputError.
#pragma once

#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "capture/frame_source.h"
#include "capture/pixel_format.h"

namespace gonio::capture {

// Whether this build has the libcamera backend.
bool HaveLibcamera();

// One entry per camera libcamera sees ({"backend": "libcamera", "id", "model", "formats"}).
nlohmann::json ListLibcameraCameras();

class LibcameraSource : public FrameSource {
 public:
  struct Options {
    // A libcamera camera id, an index into the camera list ("0"), or a /dev/videoN node that
    // libcamera drives. Empty: the first camera.
    std::string camera;
    FormatRequest format;
    int buffers = 4;
    // Frames to wait at most for the metadata to report a new exposure before giving up.
    int max_settle_frames = 30;
    void Check() const;
  };

  explicit LibcameraSource(const Options& options);
  ~LibcameraSource() override;
  LibcameraSource(const LibcameraSource&) = delete;
  LibcameraSource& operator=(const LibcameraSource&) = delete;

  std::string Id() const override;
  std::string GainUnit() const override;  // analogue: libcamera's AnalogueGain, 1 = unity
  bool ControlsExposure() const override { return true; }
  void SetExposure(double exposure_s, std::optional<double> gain) override;
  void Settle() override;
  std::optional<CapturedFrame> Grab() override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gonio::capture
