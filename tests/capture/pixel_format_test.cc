#include "capture/pixel_format.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"

namespace gonio::capture {
namespace {

// BT.601 limited-range YCbCr -> RGB (ITU-R BT.601 eq. for 8-bit studio swing), written out
// independently of OpenCV so the test checks OpenCV's use, byte order and chroma sharing.
cv::Vec3d Bt601ToBgr(int y, int u, int v) {
  const double c = 1.164 * (y - 16), d = u - 128.0, e = v - 128.0;
  const auto clip = [](double x) { return std::clamp(x, 0.0, 255.0); };
  return {clip(c + 2.018 * d), clip(c - 0.391 * d - 0.813 * e), clip(c + 1.596 * e)};
}

void ExpectBgrNear(const cv::Mat& image, int row, int col, const cv::Vec3d& bgr, double tol) {
  const cv::Vec3b p = image.at<cv::Vec3b>(row, col);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(p[c], bgr[c], tol) << "pixel (" << row << "," << col << ") channel " << c;
  }
}

TEST(ConvertFrame, GreyHonoursStrideAndIgnoresPadding) {
  // 3x2 pixels, rows padded to 4 bytes with 0xEE.
  const std::vector<uint8_t> bytes = {1, 2, 3, 0xEE, 4, 5, 6, 0xEE};
  const cv::Mat m = ConvertFrame(PixelLayout::kGrey, 3, 2, 4, bytes.data(), bytes.size());
  ASSERT_EQ(m.type(), CV_8UC1);
  ASSERT_EQ(m.size(), cv::Size(3, 2));
  EXPECT_EQ(m.at<uint8_t>(0, 0), 1);
  EXPECT_EQ(m.at<uint8_t>(0, 2), 3);
  EXPECT_EQ(m.at<uint8_t>(1, 0), 4);
  EXPECT_EQ(m.at<uint8_t>(1, 2), 6);
}

TEST(ConvertFrame, DeepGreyIsLittleEndianAndScaledToSixteenBits) {
  // Y10: 0x3FF (full scale), 0x001, and 0x001 with stray high bits that must be masked.
  const std::vector<uint8_t> y10 = {0xFF, 0x03, 0x01, 0x00, 0x01, 0xFC};
  const cv::Mat m10 = ConvertFrame(PixelLayout::kY10, 3, 1, 6, y10.data(), y10.size());
  ASSERT_EQ(m10.type(), CV_16UC1);
  EXPECT_EQ(m10.at<uint16_t>(0, 0), 0xFFC0);
  EXPECT_EQ(m10.at<uint16_t>(0, 1), 0x0040);
  EXPECT_EQ(m10.at<uint16_t>(0, 2), 0x0040);
  // Linear: 1 count of Y10 is 64 counts of the output, 1 count of Y12 is 16.
  const std::vector<uint8_t> y12 = {0xBC, 0x0A, 0x00, 0x00};
  const cv::Mat m12 = ConvertFrame(PixelLayout::kY12, 2, 1, 4, y12.data(), y12.size());
  EXPECT_EQ(m12.at<uint16_t>(0, 0), 0xABC0);
  EXPECT_EQ(m12.at<uint16_t>(0, 1), 0);
  const std::vector<uint8_t> y16 = {0x34, 0x12, 0xFF, 0xFF};
  const cv::Mat m16 = ConvertFrame(PixelLayout::kY16, 2, 1, 4, y16.data(), y16.size());
  EXPECT_EQ(m16.at<uint16_t>(0, 0), 0x1234);
  EXPECT_EQ(m16.at<uint16_t>(0, 1), 0xFFFF);
}

TEST(ConvertFrame, YuyvSharesChromaBetweenPixelPairsInY0UY1VOrder) {
  // Two macropixels with different chroma; UYVY order would give very different colours.
  const std::vector<uint8_t> bytes = {81, 90, 145, 240, 210, 16, 41, 146};
  const cv::Mat m = ConvertFrame(PixelLayout::kYuyv, 4, 1, 8, bytes.data(), bytes.size());
  ASSERT_EQ(m.type(), CV_8UC3);
  ExpectBgrNear(m, 0, 0, Bt601ToBgr(81, 90, 240), 2.0);
  ExpectBgrNear(m, 0, 1, Bt601ToBgr(145, 90, 240), 2.0);
  ExpectBgrNear(m, 0, 2, Bt601ToBgr(210, 16, 146), 2.0);
  ExpectBgrNear(m, 0, 3, Bt601ToBgr(41, 16, 146), 2.0);
}

TEST(ConvertFrame, Nv12ReadsTheChromaPlaneAtStrideTimesHeight) {
  // 2x2 pixels, stride 4 (two padding bytes per row), then one U V pair for the 2x2 block.
  const std::vector<uint8_t> bytes = {16, 235, 0, 0, 126, 60, 0, 0, 200, 70, 0, 0};
  const cv::Mat m = ConvertFrame(PixelLayout::kNv12, 2, 2, 4, bytes.data(), bytes.size());
  ASSERT_EQ(m.size(), cv::Size(2, 2));
  ExpectBgrNear(m, 0, 0, Bt601ToBgr(16, 200, 70), 2.0);
  ExpectBgrNear(m, 0, 1, Bt601ToBgr(235, 200, 70), 2.0);
  ExpectBgrNear(m, 1, 0, Bt601ToBgr(126, 200, 70), 2.0);
  ExpectBgrNear(m, 1, 1, Bt601ToBgr(60, 200, 70), 2.0);
}

TEST(ConvertFrame, NeutralChromaGivesGreyLevelsOfTheStudioRange) {
  // Y = 16 is black and Y = 235 white in BT.601 studio swing.
  const std::vector<uint8_t> bytes = {16, 128, 235, 128};
  const cv::Mat m = ConvertFrame(PixelLayout::kYuyv, 2, 1, 4, bytes.data(), bytes.size());
  ExpectBgrNear(m, 0, 0, {0, 0, 0}, 1.0);
  ExpectBgrNear(m, 0, 1, {255, 255, 255}, 1.0);
}

TEST(ConvertFrame, Rgb24IsReorderedToBgr) {
  const std::vector<uint8_t> bytes = {10, 20, 30};
  const cv::Mat rgb = ConvertFrame(PixelLayout::kRgb24, 1, 1, 3, bytes.data(), bytes.size());
  EXPECT_EQ(rgb.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
  const cv::Mat bgr = ConvertFrame(PixelLayout::kBgr24, 1, 1, 3, bytes.data(), bytes.size());
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
}

TEST(ConvertFrame, MjpegDecodesAndRejectsCorruptOrMisSizedFrames) {
  cv::Mat ramp(8, 16, CV_8UC1);
  for (int r = 0; r < ramp.rows; ++r) {
    for (int c = 0; c < ramp.cols; ++c) ramp.at<uint8_t>(r, c) = static_cast<uint8_t>(16 * c);
  }
  std::vector<uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", ramp, jpeg, {cv::IMWRITE_JPEG_QUALITY, 100}));
  const cv::Mat m = ConvertFrame(PixelLayout::kMjpeg, 16, 8, 0, jpeg.data(), jpeg.size());
  ASSERT_EQ(m.type(), CV_8UC1);
  double max_error = 0.0;
  cv::minMaxLoc(cv::abs(m - ramp), nullptr, &max_error);
  EXPECT_LE(max_error, 3.0);  // quality-100 JPEG of a smooth ramp
  // A frame of the wrong size (a camera that switched modes) and garbage both give nothing.
  EXPECT_TRUE(ConvertFrame(PixelLayout::kMjpeg, 32, 8, 0, jpeg.data(), jpeg.size()).empty());
  std::vector<uint8_t> garbage(jpeg.size(), 0x55);
  EXPECT_TRUE(ConvertFrame(PixelLayout::kMjpeg, 16, 8, 0, garbage.data(), garbage.size()).empty());
}

// Many UVC cameras send MJPEG frames without DHT segments (the decoder is expected to use the
// standard Huffman tables of JPEG Annex K.3). Strip them from a JPEG OpenCV encoded with the
// standard tables and check the frame still decodes to the same pixels.
TEST(ConvertFrame, MjpegWithoutHuffmanTablesAsUvcCamerasSendIt) {
  cv::Mat ramp(8, 16, CV_8UC1);
  for (int r = 0; r < ramp.rows; ++r) {
    for (int c = 0; c < ramp.cols; ++c) ramp.at<uint8_t>(r, c) = static_cast<uint8_t>(16 * c);
  }
  std::vector<uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", ramp, jpeg, {cv::IMWRITE_JPEG_QUALITY, 100}));
  const cv::Mat with_tables = ConvertFrame(PixelLayout::kMjpeg, 16, 8, 0, jpeg.data(), jpeg.size());
  ASSERT_FALSE(with_tables.empty());
  std::vector<uint8_t> stripped(jpeg.begin(), jpeg.begin() + 2);  // SOI
  int removed = 0;
  for (size_t i = 2; i + 4 <= jpeg.size();) {
    ASSERT_EQ(jpeg[i], 0xFF);
    const int marker = jpeg[i + 1];
    const size_t length = (static_cast<size_t>(jpeg[i + 2]) << 8) | jpeg[i + 3];
    if (marker == 0xDA) {  // start of scan: the rest is entropy-coded data
      stripped.insert(stripped.end(), jpeg.begin() + i, jpeg.end());
      break;
    }
    if (marker == 0xC4) {
      ++removed;
    } else {
      stripped.insert(stripped.end(), jpeg.begin() + i, jpeg.begin() + i + 2 + length);
    }
    i += 2 + length;
  }
  ASSERT_GT(removed, 0);
  const cv::Mat m = ConvertFrame(PixelLayout::kMjpeg, 16, 8, 0, stripped.data(), stripped.size());
  ASSERT_FALSE(m.empty());
  EXPECT_EQ(cv::norm(m, with_tables, cv::NORM_INF), 0.0);
}

TEST(ConvertFrame, TruncatedFramesGiveAnEmptyImage) {
  const std::vector<uint8_t> bytes(7, 0);
  EXPECT_TRUE(ConvertFrame(PixelLayout::kGrey, 4, 2, 4, bytes.data(), bytes.size()).empty());
  EXPECT_TRUE(ConvertFrame(PixelLayout::kY16, 2, 2, 4, bytes.data(), bytes.size()).empty());
  // NV12 needs 1.5 rows of chroma-inclusive data per row: 2x2 at stride 2 is 6 bytes.
  EXPECT_TRUE(ConvertFrame(PixelLayout::kNv12, 2, 2, 2, bytes.data(), 5).empty());
  EXPECT_FALSE(ConvertFrame(PixelLayout::kNv12, 2, 2, 2, bytes.data(), 6).empty());
  // Stride shorter than a row is a driver bug, not a frame.
  EXPECT_TRUE(ConvertFrame(PixelLayout::kYuyv, 2, 1, 3, bytes.data(), bytes.size()).empty());
}

TEST(FormatRequest, ParsesLayoutAndSize) {
  EXPECT_TRUE(ParseFormatRequest("auto").any_layout);
  const FormatRequest a = ParseFormatRequest("yuyv:640x480");
  EXPECT_FALSE(a.any_layout);
  EXPECT_EQ(a.layout, PixelLayout::kYuyv);
  EXPECT_EQ(a.width, 640);
  EXPECT_EQ(a.height, 480);
  const FormatRequest b = ParseFormatRequest("1280x720");
  EXPECT_TRUE(b.any_layout);
  EXPECT_EQ(b.width, 1280);
  EXPECT_EQ(ParseFormatRequest("MJPEG").layout, PixelLayout::kMjpeg);
  EXPECT_THROW(ParseFormatRequest("H264"), InputError);
  EXPECT_THROW(ParseFormatRequest("YUYV:640"), InputError);
}

std::vector<FormatOption> Webcam() {
  return {{PixelLayout::kMjpeg, {{1920, 1920, 1, 1080, 1080, 1}, {640, 640, 1, 480, 480, 1}}},
          {PixelLayout::kYuyv, {{640, 640, 1, 480, 480, 1}, {1280, 1280, 1, 720, 720, 1}}}};
}

TEST(ChooseFormat, PrefersUncompressedAndTheLargestSize) {
  const ChosenFormat c = ChooseFormat(Webcam(), FormatRequest{}, "/dev/video0");
  EXPECT_EQ(c.layout, PixelLayout::kYuyv);
  EXPECT_EQ(c.width, 1280);
  EXPECT_EQ(c.height, 720);
}

TEST(ChooseFormat, FallsBackWhenThePreferredLayoutLacksTheSize) {
  FormatRequest r;
  r.width = 1920;
  r.height = 1080;
  const ChosenFormat c = ChooseFormat(Webcam(), r, "/dev/video0");
  EXPECT_EQ(c.layout, PixelLayout::kMjpeg);
}

TEST(ChooseFormat, DeepGreyWinsAndStepwiseRangesHonourTheirStep) {
  std::vector<FormatOption> offered = Webcam();
  offered.push_back({PixelLayout::kY12, {{32, 2048, 16, 32, 1536, 2}}});
  FormatRequest r;
  r.width = 1024;
  r.height = 768;
  EXPECT_EQ(ChooseFormat(offered, r, "cam").layout, PixelLayout::kY12);
  r.width = 1008;  // on the 16-pixel step from 32
  r.height = 480;
  EXPECT_EQ(ChooseFormat(offered, r, "cam").layout, PixelLayout::kY12);
  r.width = 1000;  // not on the step, and no discrete size either
  EXPECT_THROW(ChooseFormat(offered, r, "cam"), InputError);
  EXPECT_EQ(ChooseFormat(offered, FormatRequest{}, "cam").width, 2048);
}

TEST(ChooseFormat, ImpossibleRequestsNameTheDeviceAndListTheOffer) {
  FormatRequest r = ParseFormatRequest("GREY");
  try {
    ChooseFormat(Webcam(), r, "/dev/video3");
    FAIL();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("/dev/video3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("YUYV 640x480,1280x720"), std::string::npos) << msg;
  }
  r = ParseFormatRequest("YUYV:800x600");
  EXPECT_THROW(ChooseFormat(Webcam(), r, "/dev/video3"), InputError);
  EXPECT_THROW(ChooseFormat({}, FormatRequest{}, "/dev/video3"), InputError);
}

}  // namespace
}  // namespace gonio::capture
