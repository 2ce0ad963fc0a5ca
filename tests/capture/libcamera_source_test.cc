// What of the libcamera backend runs without a camera: the camera manager starts, enumerates
// and stops, and asking for a camera that is not there is a one-line InputError.
#include "capture/libcamera_source.h"

#include <gtest/gtest.h>

#include "common/error.h"

namespace gonio::capture {
namespace {

TEST(Libcamera, ListingDescribesEveryCameraItSees) {
  const nlohmann::json cameras = ListLibcameraCameras();
  ASSERT_TRUE(cameras.is_array());
  if (!HaveLibcamera()) {
    EXPECT_TRUE(cameras.empty());
  }
  for (const auto& c : cameras) {
    EXPECT_EQ(c["backend"], "libcamera");
    EXPECT_TRUE(c.contains("id") && c.contains("formats")) << c.dump();
  }
}

TEST(Libcamera, AMissingCameraIsAnInputErrorNamingIt) {
  const size_t n = ListLibcameraCameras().size();
  LibcameraSource::Options o;
  o.camera = std::to_string(n);  // one past the last camera
  try {
    LibcameraSource source(o);
    FAIL();
  } catch (const InputError& e) {
    // The whole message: the camera asked for and why it cannot be had (a bare find() of a
    // one-digit index would accept almost any message).
    const std::string msg = e.what();
    if (!HaveLibcamera()) {
      EXPECT_NE(msg.find("built without libcamera"), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    } else if (n == 0) {
      EXPECT_EQ(msg, "0: no camera found by libcamera");
    } else {
      EXPECT_EQ(msg,
                "libcamera: camera " + o.camera + " does not exist (" + o.camera + " cameras)");
    }
  }
}

}  // namespace
}  // namespace gonio::capture
