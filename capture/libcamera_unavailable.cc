// The libcamera backend's entry points in a build without libcamera (see libcamera_source.cc).
#include "capture/libcamera_source.h"
#include "common/error.h"

namespace gonio::capture {

struct LibcameraSource::Impl {};

bool HaveLibcamera() { return false; }

nlohmann::json ListLibcameraCameras() { return nlohmann::json::array(); }

void LibcameraSource::Options::Check() const {}

LibcameraSource::LibcameraSource(const Options& options) {
  throw InputError(
      "--backend libcamera: this gonio was built without libcamera "
      "(install libcamera-dev and rebuild)");
}
LibcameraSource::~LibcameraSource() = default;
std::string LibcameraSource::Id() const { return ""; }
std::string LibcameraSource::GainUnit() const { return ""; }
void LibcameraSource::SetExposure(double, std::optional<double>) {}
void LibcameraSource::Settle() {}
std::optional<CapturedFrame> LibcameraSource::Grab() { return std::nullopt; }

}  // namespace gonio::capture
