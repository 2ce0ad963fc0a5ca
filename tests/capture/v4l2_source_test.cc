// What of the V4L2 backend can run without a camera: the pure helpers, and the error paths of
// opening something that is not a capture device.
#include "capture/v4l2_source.h"

#include <fstream>

#include <gtest/gtest.h>
#include <linux/videodev2.h>

#include "common/error.h"
#include "tests/test_util.h"

namespace gonio::capture {
namespace {

TEST(V4l2Fourcc, MapsEveryLayoutBothWays) {
  for (PixelLayout layout : AllLayouts()) {
    const uint32_t fourcc = V4l2Fourcc(layout);
    ASSERT_NE(fourcc, 0u) << LayoutName(layout);
    EXPECT_EQ(LayoutFromV4l2Fourcc(fourcc), layout) << LayoutName(layout);
    // The user-facing names are the fourccs v4l2-ctl prints.
    EXPECT_EQ(FourccToString(fourcc), LayoutName(layout));
  }
  EXPECT_EQ(LayoutFromV4l2Fourcc(V4L2_PIX_FMT_JPEG), PixelLayout::kMjpeg);
  EXPECT_FALSE(LayoutFromV4l2Fourcc(V4L2_PIX_FMT_H264).has_value());
  EXPECT_EQ(FourccToString(V4L2_PIX_FMT_H264), "H264");
}

TEST(ChooseFramePeriod, FastestRateThatFitsTheLongestExposure) {
  // A UVC camera's discrete intervals: 30, 15, 10, 5 fps.
  const std::vector<PeriodRange> uvc = {
      {1.0 / 30, 1.0 / 30}, {1.0 / 15, 1.0 / 15}, {0.1, 0.1}, {0.2, 0.2}};
  EXPECT_DOUBLE_EQ(ChooseFramePeriod(uvc, 0.016), 1.0 / 30);
  EXPECT_DOUBLE_EQ(ChooseFramePeriod(uvc, 0.05), 1.0 / 15);
  EXPECT_DOUBLE_EQ(ChooseFramePeriod(uvc, 0.08), 0.1);
  EXPECT_DOUBLE_EQ(ChooseFramePeriod(uvc, 0.1), 0.1);
  // Longer than any frame: the slowest rate (the device clips; the read-back shows it).
  EXPECT_DOUBLE_EQ(ChooseFramePeriod(uvc, 1.0), 0.2);
  // A continuous range gives exactly the exposure, clamped to the range.
  EXPECT_DOUBLE_EQ(ChooseFramePeriod({{0.01, 2.0}}, 0.5), 0.5);
  EXPECT_DOUBLE_EQ(ChooseFramePeriod({{0.01, 2.0}}, 0.001), 0.01);
  EXPECT_DOUBLE_EQ(ChooseFramePeriod({}, 0.5), 0.0);
}

TEST(V4l2Source, MissingNodeNamesItAndTheReason) {
  try {
    V4l2Source::Options o;
    o.device = "/dev/video99";
    V4l2Source source(o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "/dev/video99: cannot open (No such file or directory)");
  }
}

TEST(V4l2Source, AFileThatIsNoDeviceIsRefused) {
  testing::TempDir dir;
  const auto file = dir.path() / "video0";
  std::ofstream(file) << "not a camera";
  try {
    QueryV4l2Device(file.string());
    FAIL();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg, file.string() + ": cannot open (not a V4L2 device)");
  }
}

TEST(V4l2Source, OptionsAreChecked) {
  V4l2Source::Options o;
  o.buffers = 1;
  EXPECT_THROW(o.Check(), InputError);
  o.buffers = 4;
  o.device.clear();
  EXPECT_THROW(o.Check(), InputError);
}

}  // namespace
}  // namespace gonio::capture
