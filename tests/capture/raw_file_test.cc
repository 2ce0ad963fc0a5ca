// RAW import: DNG files written here with libtiff (CFA pattern, BlackLevel, WhiteLevel,
// ExposureTime, ISO), read back through LibRaw by capture/raw_file.h and `gonio capture`.
// The truth is the mosaic this test writes, not anything the code under test computes.
#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/photometric.h"
#include "capture/file_sources.h"
#include "capture/raw_file.h"
#include "common/error.h"
#include "common/session.h"
#include "tests/capture/dng_writer.h"
#include "tests/test_util.h"

namespace gonio::capture {
namespace {

namespace fs = std::filesystem;

constexpr double kBlack = 256, kWhite = 4095;  // a 12-bit sensor with a pedestal
constexpr int kWidth = 64, kHeight = 48;

// Linear signal above black per colour at 2x2 block (x, y) of the mosaic; block (5, 3) has a
// saturated green photosite.
double Signal(char colour, int second_green, int x, int y) {
  switch (colour) {
    case 'R':
      return 100 + 10 * x;
    case 'B':
      return 300 + x + y;
    default:
      return 2000 + 5 * y + 2 * second_green;
  }
}

struct BayerSpec {
  std::string cfa = "RGGB";
  double exposure_s = 1.0 / 125;
  int iso = 200;
  bool with_exposure = true;
};

// A Bayer DNG whose photosites carry Signal() above kBlack.
void WriteDng(const fs::path& path, const BayerSpec& bayer) {
  gonio::testing::DngSpec spec;
  spec.width = kWidth;
  spec.height = kHeight;
  spec.cfa = bayer.cfa;
  spec.black = {static_cast<float>(kBlack)};
  spec.white = static_cast<uint32_t>(kWhite);
  spec.exposure_s = bayer.exposure_s;
  spec.iso = bayer.iso;
  spec.with_exposure = bayer.with_exposure;
  spec.value = [cfa = bayer.cfa](int c, int r, int) {
    const char colour = cfa[(r % 2) * 2 + c % 2];
    const int second_green =
        colour == 'G' && cfa.find('G') != static_cast<size_t>((r % 2) * 2 + c % 2);
    double v = kBlack + Signal(colour, second_green, c / 2, r / 2);
    if (colour == 'G' && c / 2 == 5 && r / 2 == 3) v = kWhite;
    return static_cast<uint16_t>(v);
  };
  gonio::testing::WriteDng(path, spec);
}

double Expected(char colour, int x, int y) {
  const double signal =
      colour == 'G' ? 0.5 * (Signal('G', 0, x, y) + Signal('G', 1, x, y)) : Signal(colour, 0, x, y);
  return signal * 65535.0 / (kWhite - kBlack);
}

class RawFile : public ::testing::TestWithParam<std::string> {};

TEST_P(RawFile, BinsTheMosaicSubtractsBlackScalesWhiteAndKeepsMetadata) {
  gonio::testing::TempDir dir;
  BayerSpec spec;
  spec.cfa = GetParam();
  const fs::path file = dir.path() / "a.DNG";
  WriteDng(file, spec);
  ASSERT_TRUE(IdentifyRaw(file).has_value());

  const RawImage raw = ReadRaw(file);
  const RawMetadata& m = raw.metadata;
  EXPECT_EQ(m.cfa, spec.cfa);
  EXPECT_DOUBLE_EQ(m.black_level, kBlack);
  EXPECT_DOUBLE_EQ(m.white_level, kWhite);
  ASSERT_TRUE(m.exposure_s && m.iso);
  EXPECT_NEAR(*m.exposure_s, spec.exposure_s, 1e-6 * spec.exposure_s);
  EXPECT_DOUBLE_EQ(*m.iso, spec.iso);
  EXPECT_EQ(m.make, "GonioTest");
  EXPECT_EQ(m.sensor_width, kWidth);
  EXPECT_EQ(m.sensor_height, kHeight);

  ASSERT_EQ(raw.image.type(), CV_16UC3);
  ASSERT_EQ(raw.image.cols, kWidth / 2);
  ASSERT_EQ(raw.image.rows, kHeight / 2);
  for (int y = 0; y < raw.image.rows; ++y) {
    for (int x = 0; x < raw.image.cols; ++x) {
      const cv::Vec3w v = raw.image.at<cv::Vec3w>(y, x);
      EXPECT_NEAR(v[2], Expected('R', x, y), 0.5) << x << "," << y;
      EXPECT_NEAR(v[0], Expected('B', x, y), 0.5) << x << "," << y;
      if (x == 5 && y == 3) {
        EXPECT_EQ(v[1], 65535) << "a saturated photosite saturates its channel";
      } else {
        EXPECT_NEAR(v[1], Expected('G', x, y), 0.5) << x << "," << y;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Patterns, RawFile, ::testing::Values("RGGB", "GBRG", "BGGR"));

TEST(RawFile, ANonRawFileIsOneLineInputError) {
  gonio::testing::TempDir dir;
  const fs::path file = dir.path() / "fake.nef";
  std::ofstream(file) << "not a raw file";
  try {
    ReadRaw(file);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("fake.nef"), std::string::npos) << e.what();
  }
}

// Fujifilm's X-Trans pattern (6x6; each 3x3 quarter holds 2 red, 5 green, 2 blue).
constexpr const char* kXTrans =
    "GGRGGB"
    "GGBGGR"
    "BRGRBG"
    "GGBGGR"
    "GGRGGB"
    "RBGBRG";

// A smooth signal per colour and photosite, so binning errors (wrong colour, wrong block)
// show: the expected block mean is computed here from the photosites this test wrote.
uint16_t XTransValue(int x, int y) {
  const char colour = kXTrans[(y % 6) * 6 + x % 6];
  const int base = colour == 'R' ? 400 : colour == 'G' ? 1500 : 900;
  return static_cast<uint16_t>(kBlack + base + 7 * x + 3 * y + (x * y) % 5);
}

TEST(RawFile, XTransIsBinnedPerThreeByThreeQuarterOfItsPattern) {
  gonio::testing::TempDir dir;
  gonio::testing::DngSpec spec;
  spec.width = 60;
  spec.height = 42;
  spec.cfa = kXTrans;
  spec.black = {static_cast<float>(kBlack)};
  spec.value = [](int x, int y, int) { return XTransValue(x, y); };
  const fs::path file = dir.path() / "xtrans.dng";
  gonio::testing::WriteDng(file, spec);
  const RawImage raw = ReadRaw(file);
  EXPECT_EQ(raw.metadata.layout, RawLayout::kColourFilterArray);
  EXPECT_EQ(raw.metadata.block, 3);
  EXPECT_EQ(raw.metadata.cfa, "GGRGGBBRG");
  ASSERT_EQ(raw.image.type(), CV_16UC3);
  ASSERT_EQ(raw.image.size(), cv::Size(20, 14));
  for (int by = 0; by < 14; ++by) {
    for (int bx = 0; bx < 20; ++bx) {
      double sum[3] = {0, 0, 0};
      int count[3] = {0, 0, 0};
      for (int y = 3 * by; y < 3 * by + 3; ++y) {
        for (int x = 3 * bx; x < 3 * bx + 3; ++x) {
          const char colour = kXTrans[(y % 6) * 6 + x % 6];
          const int c = colour == 'R' ? 2 : colour == 'G' ? 1 : 0;
          sum[c] += (XTransValue(x, y) - kBlack) * 65535.0 / (kWhite - kBlack);
          ++count[c];
        }
      }
      ASSERT_EQ(count[2], 2);
      ASSERT_EQ(count[1], 5);
      ASSERT_EQ(count[0], 2);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(raw.image.at<cv::Vec3w>(by, bx)[c], sum[c] / count[c], 0.5)
            << bx << "," << by << " channel " << c;
      }
    }
  }
}

TEST(RawFile, LinearDngBecomesAFullSizeLinearFrame) {
  gonio::testing::TempDir dir;
  for (int samples : {3, 1}) {
    gonio::testing::DngSpec spec;
    spec.cfa.clear();
    spec.linear_samples = samples;
    spec.width = 40;
    spec.height = 30;
    // One black level per sample (DNG BlackLevel with SamplesPerPixel values).
    spec.black = samples == 3 ? std::vector<float>{100, 120, 140} : std::vector<float>{100};
    spec.value = [](int x, int y, int s) {
      if (x == 7 && y == 5) return static_cast<uint16_t>(kWhite);  // a saturated pixel
      return static_cast<uint16_t>(150 + 1000 * s + 31 * x + 17 * y);
    };
    const fs::path file = dir.path() / ("linear" + std::to_string(samples) + ".dng");
    gonio::testing::WriteDng(file, spec);
    const RawImage raw = ReadRaw(file);
    EXPECT_EQ(raw.metadata.layout, samples == 3 ? RawLayout::kLinearRgb : RawLayout::kLinearGrey);
    EXPECT_EQ(raw.metadata.block, 1);
    EXPECT_EQ(raw.metadata.channels, samples);
    EXPECT_DOUBLE_EQ(raw.metadata.black_level, samples == 3 ? 120.0 : 100.0);
    ASSERT_EQ(raw.image.size(), cv::Size(40, 30));
    ASSERT_EQ(raw.image.type(), samples == 3 ? CV_16UC3 : CV_16UC1);
    for (int y = 0; y < 30; ++y) {
      for (int x = 0; x < 40; ++x) {
        for (int s = 0; s < samples; ++s) {
          const double expected =
              x == 7 && y == 5
                  ? 65535.0
                  : 65535.0 * (spec.value(x, y, s) - spec.black[s]) / (kWhite - spec.black[s]);
          // Samples are R, G, B; the frame is BGR.
          const double got =
              samples == 3 ? raw.image.at<cv::Vec3w>(y, x)[2 - s] : raw.image.at<uint16_t>(y, x);
          EXPECT_NEAR(got, expected, 0.5) << x << "," << y << " sample " << s;
        }
      }
    }
  }
}

TEST(RawFile, ACfaWithoutRedGreenAndBlueIsRefusedNamingTheFileAndWhy) {
  gonio::testing::TempDir dir;
  gonio::testing::DngSpec spec;
  spec.cfa = "CMYG";
  spec.value = [](int x, int y, int) { return static_cast<uint16_t>(500 + x + y); };
  const fs::path file = dir.path() / "cmyg.dng";
  gonio::testing::WriteDng(file, spec);
  try {
    IdentifyRaw(file);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cmyg.dng"), std::string::npos) << what;
    EXPECT_NE(what.find("colour filter array"), std::string::npos) << what;
  }
}

// LibRaw decides what is RAW, not the suffix: a DNG named without a RAW suffix is imported, a
// text sidecar, an exposure note and a binary LibRaw does not know are skipped, and a file with
// a RAW suffix that LibRaw cannot read is an error naming it.
TEST(RawImport, FolderImportIdentifiesRawFilesByContent) {
  gonio::testing::TempDir dir;
  const fs::path photos = dir.path() / "photos";
  fs::create_directories(photos);
  WriteDng(photos / "frame_0001", {});
  WriteDng(photos / "frame_0002.camera", {});
  std::ofstream(photos / "frame_0001.xmp") << "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"/>\n";
  std::ofstream(photos / "notes.txt") << "shot at 1/125 s\n";
  {
    std::ofstream bin(photos / "data.bin", std::ios::binary);
    for (int i = 0; i < 100000; ++i) bin.put(static_cast<char>((i * 7919) % 251));
  }
  const auto listed = ListImages(photos);
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].file.filename(), "frame_0001");
  EXPECT_TRUE(listed[0].raw && listed[1].raw);
  const fs::path out = dir.path() / "session";
  auto r = gonio::testing::RunGonio("capture --from-folder " + photos.string() +
                                    " --exposures-from EXIF --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadSession(out).frames.size(), 2u);

  std::ofstream(photos / "broken.CR3") << std::string(5000, '\0');
  r = gonio::testing::RunGonio("capture --from-folder " + photos.string() +
                               " --exposures-from EXIF --out " + (dir.path() / "s2").string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_EQ(gonio::testing::MessageLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("broken.CR3"), std::string::npos) << r.err;
}

TEST(RawImport, CaptureFromFolderWritesLinear16BitFramesWithExposureAndIso) {
  gonio::testing::TempDir dir;
  const fs::path photos = dir.path() / "photos";
  fs::create_directories(photos);
  BayerSpec a, b;
  b.exposure_s = 1.0 / 30;
  b.iso = 400;
  WriteDng(photos / "IMG_0001.dng", a);
  WriteDng(photos / "IMG_0002.dng", b);
  const fs::path out = dir.path() / "session";
  const auto r = gonio::testing::RunGonio("capture --from-folder " + photos.string() +
                                          " --exposures-from EXIF --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;

  const Session s = ReadSession(out);
  EXPECT_EQ(s.bit_depth, 16);
  EXPECT_EQ(s.gain_unit, Session::kGainIso100);
  EXPECT_EQ(s.camera_id, "raw:GonioTest DNG writer");
  ASSERT_EQ(s.frames.size(), 2u);
  EXPECT_NEAR(s.frames[0].exposure_s, 1.0 / 125, 1e-8);
  EXPECT_NEAR(s.frames[1].exposure_s, 1.0 / 30, 1e-8);
  EXPECT_DOUBLE_EQ(s.frames[0].gain, 2.0);
  EXPECT_DOUBLE_EQ(s.frames[1].gain, 4.0);
  const cv::Mat frame = cv::imread(s.FramePath(1).string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(frame.type(), CV_16UC3);
  EXPECT_NEAR(frame.at<cv::Vec3w>(7, 9)[2], Expected('R', 9, 7), 0.5);
  EXPECT_NEAR(frame.at<cv::Vec3w>(7, 9)[1], Expected('G', 9, 7), 0.5);

  // The session's photometric calibration is linear: radiance proportional to the value.
  const PhotometricCalibration p = PhotometricCalibration::Read(out / "photometric.json");
  EXPECT_EQ(p.response.bit_depth, 16);
  EXPECT_EQ(p.response.channels, 3);
  // Its black level is the RAW file's, already subtracted, and says so.
  EXPECT_EQ(p.response.black_level_source, BlackLevelSource::kRawMetadata);
  for (int c = 0; c < 3; ++c) {
    EXPECT_DOUBLE_EQ(p.response.black_level[c], 0.0);
    EXPECT_DOUBLE_EQ(p.response.saturation_level[c], 65535.0);
    for (int z : {1, 1000, 30000, 65534}) {
      EXPECT_NEAR(p.response.Linearize(c, z) / p.response.Linearize(c, 1000), z / 1000.0, 1e-9);
    }
  }
}

TEST(RawImport, MixedFolderAndMissingExposureExitTwoWithOneLine) {
  gonio::testing::TempDir dir;
  const fs::path mixed = dir.path() / "mixed", bare = dir.path() / "bare";
  fs::create_directories(mixed);
  fs::create_directories(bare);
  WriteDng(mixed / "a.dng", {});
  cv::imwrite((mixed / "b.png").string(), cv::Mat(8, 8, CV_8UC1, cv::Scalar(10)));
  BayerSpec no_exposure;
  no_exposure.with_exposure = false;
  WriteDng(bare / "a.dng", no_exposure);
  for (const auto& [folder, expected] :
       {std::pair{mixed, std::string("mixes RAW")}, std::pair{bare, std::string("a.dng")}}) {
    const fs::path out = dir.path() / ("s_" + folder.filename().string());
    // The PNG has no EXIF, so the mixed folder uses an exposure list.
    if (folder == mixed) std::ofstream(folder / "list.txt") << "a.dng 0.01\nb.png 0.01\n";
    const std::string from = folder == mixed ? (folder / "list.txt").string() : "EXIF";
    const auto r = gonio::testing::RunGonio("capture --from-folder " + folder.string() +
                                            " --exposures-from " + from + " --out " + out.string());
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(gonio::testing::MessageLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out / "session.json"));
  }
}

}  // namespace
}  // namespace gonio::capture
