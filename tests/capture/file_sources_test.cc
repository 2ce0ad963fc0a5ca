#include "capture/file_sources.h"

#include <fstream>

#include <gtest/gtest.h>

#include "common/error.h"
#include "tests/test_util.h"

namespace gonio::capture {
namespace {

namespace fs = std::filesystem;

TEST(Exif, ReadsExposureTimeFromTheNikonPhoto) {
  GONIO_REQUIRE_TEST_DATA();
  // apriltag/test_36h11.jpg was taken with a Nikon D80 and keeps its EXIF block. The expected
  // values were read with an independent parser (Python struct walking the TIFF IFDs):
  // ExposureTime 1/160 s, ISOSpeedRatings 1250, DateTimeOriginal 2015:09:01 17:51:23.
  const ExifExposure exif = ReadExif(testing::TestData() / "apriltag" / "test_36h11.jpg");
  ASSERT_TRUE(exif.exposure_s.has_value());
  EXPECT_DOUBLE_EQ(*exif.exposure_s, 1.0 / 160.0);
  ASSERT_TRUE(exif.iso.has_value());
  EXPECT_DOUBLE_EQ(*exif.iso, 1250.0);
  ASSERT_TRUE(exif.time_s.has_value());
  EXPECT_DOUBLE_EQ(*exif.time_s, 1441129883.0);  // 2015-09-01T17:51:23Z
  EXPECT_NE(exif.model.find("D80"), std::string::npos) << exif.model;
}

TEST(Exif, PhotosWithoutExifGiveNothingAndMissingFilesAnError) {
  GONIO_REQUIRE_TEST_DATA();
  const ExifExposure exif =
      ReadExif(testing::TestData() / "hdr_sweep" / "desktop" / "DSC_0104.png");
  EXPECT_FALSE(exif.exposure_s.has_value());
  const fs::path missing = testing::TestData() / "nope.jpg";
  try {
    ReadExif(missing);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), missing.string() + ": no such file");
  }
}

TEST(ExposureList, ReadsTheHdrSweepList) {
  GONIO_REQUIRE_TEST_DATA();
  const fs::path dir = testing::TestData() / "hdr_sweep" / "desktop";
  const auto list = ReadExposureList(dir / "image_list.txt", dir);
  ASSERT_EQ(list.size(), 13u);
  EXPECT_EQ(list.front().file.filename(), "DSC_0104.png");
  EXPECT_DOUBLE_EQ(list.front().exposure_s, 32.0);
  EXPECT_EQ(list.back().file.filename(), "DSC_0116.png");
  EXPECT_DOUBLE_EQ(list.back().exposure_s, 0.0078125);
  // 1-stop steps, as the data README says.
  for (size_t i = 1; i < list.size(); ++i) {
    EXPECT_DOUBLE_EQ(list[i - 1].exposure_s / list[i].exposure_s, 2.0);
  }
}

TEST(ExposureList, BadListsNameTheLine) {
  testing::TempDir dir;
  std::ofstream(dir.path() / "a.png") << "x";
  const fs::path list = dir.path() / "list.txt";
  const auto expect_error = [&](const std::string& text, const std::string& problem) {
    std::ofstream(list) << text;
    try {
      ReadExposureList(list, dir.path());
      FAIL() << problem;
    } catch (const InputError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(problem), std::string::npos) << msg;
    }
  };
  // A list with another third column (here an f-number) is caught by the 1/exposure check.
  expect_error("# header\na.png 0.5 2.8\n", "list.txt:2: third field 2.8 is not 1/0.5");
  expect_error("a.png\n", "list.txt:1: expected");
  expect_error("a.png fast\n", "list.txt:1: exposure");
  expect_error("b.png 0.5\n", "b.png does not exist");
  expect_error("# nothing\n", "lists no images");
}

TEST(FolderSource, DeliversImagesUnchangedWithTheirExposures) {
  GONIO_REQUIRE_TEST_DATA();
  const fs::path dir = testing::TestData() / "hdr_sweep" / "desktop";
  FolderSource source(
      "folder:test", "analogue",
      {{dir / "DSC_0110.png", 0.5, 1.0, 0.0}, {dir / "DSC_0111.png", 0.25, 1.0, 1.0}});
  EXPECT_FALSE(source.ControlsExposure());
  EXPECT_THROW(source.SetExposure(0.1, std::nullopt), InputError);
  const auto first = source.Grab();
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->image.size(), cv::Size(1024, 680));
  EXPECT_DOUBLE_EQ(first->exposure_s, 0.5);
  ASSERT_TRUE(source.Grab().has_value());
  EXPECT_FALSE(source.Grab().has_value());
}

TEST(ListImages, FindsImagesSortedByName) {
  GONIO_REQUIRE_TEST_DATA();
  const auto images = ListImages(testing::TestData() / "hdr_sweep" / "desktop");
  ASSERT_EQ(images.size(), 13u);
  EXPECT_EQ(images.front().file.filename(), "DSC_0104.png");
  EXPECT_FALSE(images.front().raw);
  EXPECT_THROW(ListImages(testing::TestData() / "no_such_folder"), InputError);
}

}  // namespace
}  // namespace gonio::capture
