// Detection: libapriltag's corner order and pixel convention measured on a rendered tag, the
// real AprilTag photo, the real OpenCV chessboards, and the corners.vnl round trip.
#include "calib/geometry/detect.h"

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

// Tag 7 of tag36h11 drawn upright with `scale` px per bit cell on white (255; black 0), top-left
// image pixel of the tag image at (offset, offset), unblurred. apriltag_to_image draws the white
// border too (total_width cells); the black square's outer edge is 1 cell inside.
cv::Mat TagCells(int scale, int offset, int* total_width) {
  apriltag_family_t* tf = tag36h11_create();
  image_u8_t* tag = apriltag_to_image(tf, 7);
  *total_width = tag->width;
  cv::Mat small(tag->height, tag->width, CV_8UC1);
  for (int y = 0; y < tag->height; ++y) {
    for (int x = 0; x < tag->width; ++x) small.at<uint8_t>(y, x) = tag->buf[y * tag->stride + x];
  }
  image_u8_destroy(tag);
  tag36h11_destroy(tf);
  cv::Mat big;
  cv::resize(small, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
  cv::Mat img(big.rows + 2 * offset, big.cols + 2 * offset, CV_8UC1, cv::Scalar(255));
  big.copyTo(img(cv::Rect(offset, offset, big.cols, big.rows)));
  return img;
}

// TagCells with dark 40, bright 220 and a slight blur: an edge then sits where the cells'
// boundary is.
cv::Mat RenderTag(int scale, int offset, int* total_width) {
  cv::Mat img = TagCells(scale, offset, total_width);
  img.convertTo(img, CV_8U, 180.0 / 255.0, 40);
  cv::GaussianBlur(img, img, cv::Size(5, 5), 1.0);
  return img;
}

TEST(DetectAprilTags, CornerOrderAndPixelCentreConvention) {
  const int scale = 20, offset = 50;
  int total_width = 0;
  const cv::Mat img = RenderTag(scale, offset, &total_width);
  AprilTagOptions opt;
  opt.decimate = 1.0;
  const auto tags = DetectAprilTags(img, opt);
  ASSERT_EQ(tags.size(), 1u);
  EXPECT_EQ(tags[0].id, 7);
  // Cell boundary j lies between pixels offset + j*scale - 1 and offset + j*scale, i.e. at
  // offset + j*scale - 0.5 with pixel centres at integers (gonio's convention).
  const double lo = offset + 1 * scale - 0.5, hi = offset + (total_width - 1) * scale - 0.5;
  const Eigen::Vector2d expected[4] = {{lo, hi}, {hi, hi}, {hi, lo}, {lo, lo}};
  for (int c = 0; c < 4; ++c) {
    // Order: 0.2 px, far below the 160 px tag width. libapriltag's edge refinement puts each
    // edge ~0.12 px outward on this blurred rendering (a scale bias of 0.15 %, symmetric).
    EXPECT_NEAR(tags[0].corners[c].x(), expected[c].x(), 0.2) << "corner " << c;
    EXPECT_NEAR(tags[0].corners[c].y(), expected[c].y(), 0.2) << "corner " << c;
  }
  // Convention: the tag's centre is free of that symmetric bias; 0.05 px tolerance separates
  // the right convention from the 0.5 px shift of the other.
  const Eigen::Vector2d centre =
      (tags[0].corners[0] + tags[0].corners[1] + tags[0].corners[2] + tags[0].corners[3]) / 4;
  EXPECT_NEAR(centre.x(), (lo + hi) / 2, 0.05);
  EXPECT_NEAR(centre.y(), (lo + hi) / 2, 0.05);
}

TEST(DetectAprilTags, RealPhotoFindsAll80Ids) {
  GONIO_REQUIRE_TEST_DATA();
  const cv::Mat img = ReadGreyImage(testing::TestData() / "apriltag/test_36h11.jpg");
  AprilTagOptions opt;
  opt.decimate = 4.0;
  opt.threads = 2;
  const auto tags = DetectAprilTags(img, opt);
  std::vector<int> ids;
  for (const auto& t : tags) ids.push_back(t.id);
  std::vector<int> expected;
  for (int r = 0; r < 8; ++r) {
    for (int c = 0; c < 10; ++c) expected.push_back(14 + 24 * r + c);
  }
  EXPECT_EQ(ids, expected);
}

TEST(DetectBoard, RealChessboardsAllFound) {
  GONIO_REQUIRE_TEST_DATA();
  const Board board = Board::FromJson(
      {{"type", "chessboard"}, {"inner_corners", {9, 6}}, {"square_size", 0.025}}, "test");
  int found = 0;
  for (const char* name : {"left01.jpg", "left02.jpg", "left03.jpg", "left04.jpg", "left05.jpg",
                           "left06.jpg", "left07.jpg", "left08.jpg", "left09.jpg", "left11.jpg",
                           "left12.jpg", "left13.jpg", "left14.jpg"}) {
    const cv::Mat img = ReadGreyImage(testing::TestData() / "opencv_chess" / name);
    const auto obs = DetectBoard(img, board, AprilTagOptions(), name);
    if (obs.pixels.size() == 54u) ++found;
  }
  EXPECT_EQ(found, 13);
}

TEST(DetectBoard, UnreadableImageIsInputError) {
  testing::TempDir dir;
  const auto bad = dir.path() / "bad.png";
  { std::ofstream(bad) << "not a png"; }
  EXPECT_THROW(ReadGreyImage(bad), InputError);
  EXPECT_THROW(ReadGreyImage(dir.path() / "missing.png"), InputError);
}

// A JPEG (told by its first bytes, whatever its name) gives its luma channel: a saturated red
// with dark stripes, whose BGR decode clips, reads as the grey the file encodes. Session frames
// (kAsStored) and other formats keep the BGR -> grey of the stored decode.
TEST(ReadGreyImage, JpegGivesItsLumaOtherFormatsTheirStoredGrey) {
  testing::TempDir dir;
  cv::Mat colour(64, 96, CV_8UC3, cv::Scalar(0, 0, 255));
  for (int x = 0; x < colour.cols; x += 8) colour.col(x).setTo(cv::Scalar(0, 40, 20));
  const auto jpeg = dir.path() / "frame.jpg", misnamed = dir.path() / "jpeg.png",
             png = dir.path() / "frame.png";
  ASSERT_TRUE(cv::imwrite(jpeg.string(), colour));
  std::filesystem::copy_file(jpeg, misnamed);
  ASSERT_TRUE(cv::imwrite(png.string(), colour));
  const cv::Mat luma = cv::imread(jpeg.string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat from_bgr = GreyForDetection(cv::imread(jpeg.string(), cv::IMREAD_UNCHANGED));
  ASSERT_GT(cv::norm(luma, from_bgr, cv::NORM_INF), 0);  // the case this test is about
  EXPECT_EQ(cv::norm(ReadGreyImage(jpeg), luma, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(ReadGreyImage(misnamed), luma, cv::NORM_INF), 0);
  EXPECT_EQ(
      cv::norm(ReadGreyImage(jpeg, 0, ImageExpectation::Jpeg::kAsStored), from_bgr, cv::NORM_INF),
      0);
  EXPECT_EQ(cv::norm(ReadGreyImage(png), GreyForDetection(colour), cv::NORM_INF), 0);
}

TEST(CornersVnl, RoundTripThroughMrcalLattice) {
  const Board board = Board::FromJson({{"type", "apriltag-grid"},
                                       {"family", "tag36h11"},
                                       {"tag_size", 0.03},
                                       {"pitch", 0.036},
                                       {"columns", 2},
                                       {"rows", 2},
                                       {"ids", {1, 2, 3, 4}}},
                                      "test");
  BoardObservation a;
  a.image = "a.png";
  for (int p : {0, 1, 2, 3, 12, 13, 14, 15}) {
    a.point_index.push_back(p);
    a.pixels.emplace_back(10.0 + p, 20.0 + 0.5 * p);
  }
  BoardObservation empty;
  empty.image = "b.png";
  testing::TempDir dir;
  std::ofstream(dir.path() / "corners.vnl") << ToCornersVnl(board, {a, empty});
  const auto back = ReadCornersVnl(dir.path() / "corners.vnl", board);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_TRUE(back[1].pixels.empty());
  ASSERT_EQ(back[0].pixels.size(), 8u);
  for (size_t i = 0; i < 8; ++i) {
    const int p = back[0].point_index[i];
    EXPECT_NEAR(back[0].pixels[i].x(), 10.0 + p, 1e-4);
    EXPECT_NEAR(back[0].pixels[i].y(), 20.0 + 0.5 * p, 1e-4);
  }
  EXPECT_EQ(back[0].tag_ids, (std::vector<int>{1, 4}));
}

// A lens blurs radiance; a gamma-encoded camera then writes each value through its curve, steep
// in the dark, and libapriltag's edge refinement (the centroid of the grey's gradient across an
// edge) moves to the black side: the tag reads small. Through the camera's inverse response
// (RadianceTable) the grey is radiance again and the edges sit where the cells' boundaries are.
// Truth: the rendering's own cell boundaries (as in CornerOrderAndPixelCentreConvention).
TEST(GreyForDetection, OnRadianceAGammaCamerasTagKeepsItsSize) {
  const int scale = 5, offset = 30;  // a 40 px black square, as the coverage bench's tags
  int total_width = 0;
  // Radiance: black 0.05, white 0.8, blurred by a lens of 1.2 px.
  cv::Mat radiance;
  TagCells(scale, offset, &total_width).convertTo(radiance, CV_64F, 0.75 / 255, 0.05);
  cv::GaussianBlur(radiance, radiance, cv::Size(9, 9), 1.2);
  // An sRGB-like camera: value = 255 (radiance / 0.9)^(1 / 2.2); its inverse response.
  cv::Mat frame(radiance.size(), CV_8U);
  for (int y = 0; y < frame.rows; ++y) {
    for (int x = 0; x < frame.cols; ++x) {
      frame.at<uint8_t>(y, x) =
          cv::saturate_cast<uint8_t>(255.0 * std::pow(radiance.at<double>(y, x) / 0.9, 1 / 2.2));
    }
  }
  RadianceTable inverse(1, std::vector<float>(256));
  for (int v = 0; v < 256; ++v) inverse[0][v] = static_cast<float>(0.9 * std::pow(v / 255.0, 2.2));
  const double lo = offset + 1 * scale - 0.5, hi = offset + (total_width - 1) * scale - 0.5;
  const Eigen::Vector2d centre((lo + hi) / 2, (lo + hi) / 2);
  // The corners' size against the truth's: sum (c - m).(e - m) / sum |e - m|^2 - 1.
  const auto size_error = [&](const cv::Mat& grey) {
    AprilTagOptions opt;
    opt.decimate = 1.0;
    const auto tags = DetectAprilTags(grey, opt);
    EXPECT_EQ(tags.size(), 1u);
    if (tags.size() != 1) return std::numeric_limits<double>::quiet_NaN();
    const Eigen::Vector2d expected[4] = {{lo, hi}, {hi, hi}, {hi, lo}, {lo, lo}};
    double dot = 0, norm = 0;
    for (int c = 0; c < 4; ++c) {
      dot += (tags[0].corners[c] - centre).dot(expected[c] - centre);
      norm += (expected[c] - centre).squaredNorm();
    }
    return dot / norm - 1;
  };
  const double as_encoded = size_error(GreyForDetection(frame));
  const double on_radiance = size_error(GreyForDetection(frame, 8, inverse));
  // Measured: -2.14 % as encoded (0.6 px over the 28 px half-diagonal); +0.41 % on radiance,
  // libapriltag's own outward refinement on a blurred edge (CornerOrderAndPixelCentreConvention).
  EXPECT_LT(as_encoded, -0.018);
  EXPECT_LT(std::abs(on_radiance), 0.005);
  // The table must fit the frames: a 12-bit table on an 8-bit frame is refused, naming both.
  RadianceTable twelve(1, std::vector<float>(4096, 1.0f));
  EXPECT_THROW(GreyForDetection(frame, 8, twelve), InputError);
}

}  // namespace
}  // namespace gonio

namespace gonio {
namespace {

// A 12-bit camera's frame in a 16-bit file, exposed to 1/8 of its range (a short exposure of a
// sweep): the real tag photo's values mapped to 0..511. Divided by 256 it would reach
// libapriltag with two grey levels and no tag; scaled by its own bright level every id is found.
TEST(GreyForDetection, DarkTwelveBitFrameKeepsEveryTag) {
  GONIO_REQUIRE_TEST_DATA();
  const cv::Mat eight = ReadGreyImage(testing::TestData() / "apriltag/test_36h11.jpg");
  cv::Mat twelve;
  eight.convertTo(twelve, CV_16U, 511.0 / 255.0);
  AprilTagOptions opt;
  opt.decimate = 4.0;
  opt.threads = 2;
  const auto reference = DetectAprilTags(eight, opt);
  ASSERT_EQ(reference.size(), 80u);
  const cv::Mat grey = GreyForDetection(twelve, 12);
  double max_value = 0;
  cv::minMaxLoc(grey, nullptr, &max_value);
  EXPECT_GE(max_value, 250);
  EXPECT_EQ(DetectAprilTags(grey, opt).size(), reference.size());
  // The old mapping (value / 256) for comparison: the tags are lost.
  cv::Mat divided;
  twelve.convertTo(divided, CV_8U, 1.0 / 256.0);
  EXPECT_LT(DetectAprilTags(divided, opt).size(), 10u);
  // A black frame stays black (the gain is bounded), not stretched noise.
  const cv::Mat black(100, 100, CV_16U, cv::Scalar(3));
  cv::minMaxLoc(GreyForDetection(black, 12), nullptr, &max_value);
  EXPECT_LE(max_value, 12);
}

}  // namespace
}  // namespace gonio
