// RAW import on real camera files (../shared/data/raw: a Nikon D1X NEF and two Raspberry Pi
// IMX296 DNGs written by picamera2). The truth is LibRaw's own unprocessed values computed here:
// raw2image + subtract_black (LibRaw's black subtraction, which also lowers its white level by
// the black), then 65535 v / white per photosite, averaged per colour over each 2x2 block, the
// channel saturated where a photosite reaches the file's white level. The metadata are checked
// against what the data's README states (exposure, ISO, black and white levels, CFA).
#include <libraw/libraw.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "capture/file_sources.h"
#include "capture/raw_file.h"
#include "tests/test_util.h"

namespace gonio::capture {
namespace {

namespace fs = std::filesystem;

struct RealRaw {
  std::string file;
  double exposure_s, iso, black, white;
  int width, height;  // visible photosites
  // Whether LibRaw reports the ISO: PiDNG's Captured_Images file stores ISOSpeedRatings in
  // IFD0 instead of the EXIF IFD, where LibRaw 0.20 does not look (the import then takes the
  // gains as equal).
  bool iso_read = true;
};

// From ../shared/data/README.md.
const RealRaw kFiles[] = {
    {"NIKON_UB20_O35.NEF", 1.0 / 180, 125, 0, 4095, 4024, 1324},
    {"image_c21ff2bc.dng", 1.0 / 100, 100, 60, 1023, 1456, 1088},
    {"Captured_Images_image_0_54b915bb.dng", 1.0 / 1689, 101, 60, 1023, 1456, 1088, false},
};

// LibRaw's black-subtracted photosite values binned as gonio bins them: BGR per 2x2 block.
// LibRaw clamps each photosite at its black level; gonio clamps only the block's mean (so read
// noise about the black level averages out instead of being rectified). Where LibRaw clamped,
// the photosite's value is its raw value less the black level LibRaw subtracted from the
// unclamped photosites of the same position in the 2x2 pattern (constant: checked).
cv::Mat LibRawBinned(const fs::path& file, double* clamped_fraction) {
  auto raw = std::make_unique<LibRaw>();
  EXPECT_EQ(raw->open_file(file.c_str()), LIBRAW_SUCCESS);
  EXPECT_EQ(raw->unpack(), LIBRAW_SUCCESS);
  const double white_raw = raw->imgdata.color.maximum;
  EXPECT_EQ(raw->raw2image(), LIBRAW_SUCCESS);
  const auto& s = raw->imgdata.sizes;
  const int w = s.width, h = s.height;
  auto at = [&](int y, int x) {
    return static_cast<double>(raw->imgdata.image[y * s.iwidth + x][raw->COLOR(y, x)]);
  };
  std::vector<double> before(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) before[y * w + x] = at(y, x);
  }
  EXPECT_EQ(raw->subtract_black(), LIBRAW_SUCCESS);
  const double white = raw->imgdata.color.maximum;  // lowered by the black level
  std::array<double, 4> black{-1, -1, -1, -1};
  size_t clamped = 0;
  std::vector<double> value(before.size());
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double after = at(y, x);
      double& b = black[(y % 2) * 2 + x % 2];
      if (after > 0) {
        if (b < 0) b = before[y * w + x] - after;
        EXPECT_EQ(before[y * w + x] - after, b) << x << "," << y;
      }
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double after = at(y, x);
      clamped += after == 0;
      value[y * w + x] = after > 0 ? after : before[y * w + x] - black[(y % 2) * 2 + x % 2];
    }
  }
  *clamped_fraction = clamped / static_cast<double>(value.size());
  cv::Mat out(h / 2, w / 2, CV_16UC3);
  for (int by = 0; by < h / 2; ++by) {
    for (int bx = 0; bx < w / 2; ++bx) {
      std::array<double, 3> sum{};
      std::array<int, 3> count{};
      std::array<bool, 3> saturated{};
      for (int y = 2 * by; y < 2 * by + 2; ++y) {
        for (int x = 2 * bx; x < 2 * bx + 2; ++x) {
          const char letter = raw->imgdata.idata.cdesc[raw->COLOR(y, x)];
          const int c = letter == 'R' ? 2 : letter == 'G' ? 1 : 0;
          sum[c] += 65535.0 * value[y * w + x] / white;
          ++count[c];
          saturated[c] = saturated[c] || before[y * w + x] >= white_raw;
        }
      }
      for (int c = 0; c < 3; ++c) {
        const double v = saturated[c] ? 65535.0 : sum[c] / count[c];
        out.at<cv::Vec3w>(by, bx)[c] =
            static_cast<uint16_t>(std::lround(std::clamp(v, 0.0, 65535.0)));
      }
    }
  }
  return out;
}

class RealRawFile : public ::testing::TestWithParam<RealRaw> {};

TEST_P(RealRawFile, MatchesLibRawsUnprocessedValuesAndStatedMetadata) {
  GONIO_REQUIRE_TEST_DATA();
  const RealRaw& truth = GetParam();
  const fs::path file = gonio::testing::TestData() / "raw" / truth.file;
  ASSERT_TRUE(fs::exists(file)) << file;
  const auto identified = IdentifyRaw(file);
  ASSERT_TRUE(identified.has_value());
  const RawImage raw = ReadRaw(file);
  const RawMetadata& m = raw.metadata;
  EXPECT_EQ(m.layout, RawLayout::kColourFilterArray);
  EXPECT_EQ(m.block, 2);
  EXPECT_EQ(m.cfa, "BGGR");
  ASSERT_TRUE(m.exposure_s);
  EXPECT_NEAR(*m.exposure_s, truth.exposure_s, 1e-3 * truth.exposure_s);
  EXPECT_EQ(m.iso.has_value(), truth.iso_read);
  if (m.iso) {
    EXPECT_DOUBLE_EQ(*m.iso, truth.iso);
  }
  EXPECT_DOUBLE_EQ(m.black_level, truth.black);
  EXPECT_DOUBLE_EQ(m.white_level, truth.white);
  EXPECT_EQ(m.sensor_width, truth.width);
  EXPECT_EQ(m.sensor_height, truth.height);

  double clamped = 0;
  const cv::Mat expected = LibRawBinned(file, &clamped);
  ASSERT_EQ(raw.image.type(), CV_16UC3);
  ASSERT_EQ(raw.image.size(), expected.size());
  cv::Mat diff;
  cv::absdiff(raw.image, expected, diff);
  double worst = 0;
  cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
  std::printf("%s: %.1f%% of the photosites at or below black, largest difference %.0f\n",
              truth.file.c_str(), 100 * clamped, worst);
  // Both round the same value to the nearest integer; they may differ by one where the
  // value sits on a half.
  EXPECT_LE(worst, 1.0) << truth.file;
  // The frame is not trivially empty: the files hold real scenes.
  double brightest = 0;
  cv::minMaxLoc(raw.image.reshape(1), nullptr, &brightest);
  EXPECT_GT(brightest, 1000.0) << truth.file;
}

INSTANTIATE_TEST_SUITE_P(SharedData, RealRawFile, ::testing::ValuesIn(kFiles),
                         [](const auto& info) {
                           std::string name = info.param.file.substr(0, 12);
                           for (char& c : name)
                             c = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
                           return name;
                         });

// The real files are recognised by content: renamed without their suffixes they are still RAW.
TEST(RealRawFile, AreIdentifiedWithoutTheirSuffixes) {
  GONIO_REQUIRE_TEST_DATA();
  gonio::testing::TempDir dir;
  for (const RealRaw& r : kFiles) {
    const fs::path copy = dir.path() / ("photo_" + std::to_string(&r - kFiles));
    fs::copy_file(gonio::testing::TestData() / "raw" / r.file, copy);
  }
  const auto photos = ListImages(dir.path());
  ASSERT_EQ(photos.size(), 3u);
  for (const auto& p : photos) EXPECT_TRUE(p.raw) << p.file;
}

}  // namespace
}  // namespace gonio::capture
