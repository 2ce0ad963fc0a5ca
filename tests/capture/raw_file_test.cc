// RAW import: DNG files written here with libtiff (CFA pattern, BlackLevel, WhiteLevel,
// ExposureTime, ISO), read back through LibRaw by capture/raw_file.h and `gonio capture`.
// The truth is the mosaic this test writes, not anything the code under test computes.
#include <tiffio.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/photometric.h"
#include "capture/raw_file.h"
#include "common/error.h"
#include "common/session.h"
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

struct DngSpec {
  std::string cfa = "RGGB";
  double exposure_s = 1.0 / 125;
  int iso = 200;
  bool with_exposure = true;
};

// Sets a tag, passing the count first when libtiff's field definition asks for one.
template <typename T>
void SetArray(TIFF* tif, uint32_t tag, const std::vector<T>& values) {
  const TIFFField* field = TIFFFindField(tif, tag, TIFF_ANY);
  ASSERT_NE(field, nullptr) << tag;
  const int ok = TIFFFieldPassCount(field)
                     ? TIFFSetField(tif, tag, static_cast<uint16_t>(values.size()), values.data())
                     : TIFFSetField(tif, tag, values.data());
  ASSERT_EQ(ok, 1) << tag;
}

void WriteDng(const fs::path& path, const DngSpec& spec) {
  TIFF* tif = TIFFOpen(path.c_str(), "w");
  ASSERT_NE(tif, nullptr);
  TIFFSetField(tif, TIFFTAG_SUBFILETYPE, 0);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, kWidth);
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, kHeight);
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 16);
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_CFA);
  TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
  TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, kHeight);
  TIFFSetField(tif, TIFFTAG_MAKE, "GonioTest");
  TIFFSetField(tif, TIFFTAG_MODEL, "DNG writer");
  SetArray<uint8_t>(tif, TIFFTAG_DNGVERSION, {1, 4, 0, 0});
  SetArray<uint16_t>(tif, TIFFTAG_CFAREPEATPATTERNDIM, {2, 2});
  std::vector<uint8_t> pattern;  // TIFF/EP colour codes: 0 red, 1 green, 2 blue
  for (char c : spec.cfa) pattern.push_back(c == 'R' ? 0 : c == 'G' ? 1 : 2);
  SetArray<uint8_t>(tif, TIFFTAG_CFAPATTERN, pattern);
  SetArray<uint8_t>(tif, TIFFTAG_CFAPLANECOLOR, {0, 1, 2});
  SetArray<float>(tif, TIFFTAG_BLACKLEVEL, {static_cast<float>(kBlack)});
  SetArray<uint32_t>(tif, TIFFTAG_WHITELEVEL, {static_cast<uint32_t>(kWhite)});
  // ExposureTime and ISO go in an EXIF IFD, as cameras write them; its offset is known only
  // once it is written, so IFD0's EXIFIFD tag is written as 0 first and set to the real
  // offset afterwards (libtiff's own EXIF test does the same).
  if (spec.with_exposure) TIFFSetField(tif, TIFFTAG_EXIFIFD, uint64_t{0});
  std::vector<uint16_t> row(kWidth);
  for (int r = 0; r < kHeight; ++r) {
    for (int c = 0; c < kWidth; ++c) {
      const char colour = spec.cfa[(r % 2) * 2 + c % 2];
      const int second_green =
          colour == 'G' && spec.cfa.find('G') != static_cast<size_t>((r % 2) * 2 + c % 2);
      double v = kBlack + Signal(colour, second_green, c / 2, r / 2);
      if (colour == 'G' && c / 2 == 5 && r / 2 == 3) v = kWhite;
      row[c] = static_cast<uint16_t>(v);
    }
    ASSERT_EQ(TIFFWriteScanline(tif, row.data(), r, 0), 1);
  }
  if (spec.with_exposure) {
    ASSERT_EQ(TIFFWriteDirectory(tif), 1);
    ASSERT_EQ(TIFFCreateEXIFDirectory(tif), 0);
    ASSERT_EQ(TIFFSetField(tif, EXIFTAG_EXPOSURETIME, spec.exposure_s), 1);
    SetArray<uint16_t>(tif, EXIFTAG_ISOSPEEDRATINGS, {static_cast<uint16_t>(spec.iso)});
    uint64_t exif_offset = 0;
    ASSERT_EQ(TIFFWriteCustomDirectory(tif, &exif_offset), 1);
    ASSERT_EQ(TIFFSetDirectory(tif, 0), 1);
    ASSERT_EQ(TIFFSetField(tif, TIFFTAG_EXIFIFD, exif_offset), 1);
  }
  TIFFClose(tif);
}

double Expected(char colour, int x, int y) {
  const double signal =
      colour == 'G' ? 0.5 * (Signal('G', 0, x, y) + Signal('G', 1, x, y)) : Signal(colour, 0, x, y);
  return signal * 65535.0 / (kWhite - kBlack);
}

class RawFile : public ::testing::TestWithParam<std::string> {};

TEST_P(RawFile, BinsTheMosaicSubtractsBlackScalesWhiteAndKeepsMetadata) {
  gonio::testing::TempDir dir;
  DngSpec spec;
  spec.cfa = GetParam();
  const fs::path file = dir.path() / "a.DNG";
  WriteDng(file, spec);
  ASSERT_TRUE(IsRawFile(file));

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

  ASSERT_EQ(raw.bgr.type(), CV_16UC3);
  ASSERT_EQ(raw.bgr.cols, kWidth / 2);
  ASSERT_EQ(raw.bgr.rows, kHeight / 2);
  for (int y = 0; y < raw.bgr.rows; ++y) {
    for (int x = 0; x < raw.bgr.cols; ++x) {
      const cv::Vec3w v = raw.bgr.at<cv::Vec3w>(y, x);
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

TEST(RawImport, CaptureFromFolderWritesLinear16BitFramesWithExposureAndIso) {
  gonio::testing::TempDir dir;
  const fs::path photos = dir.path() / "photos";
  fs::create_directories(photos);
  DngSpec a, b;
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
  DngSpec no_exposure;
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
