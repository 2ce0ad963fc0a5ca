// gonio board end to end: the printed PDF, rasterised by poppler's pdftoppm (not by the code
// under test), must carry tags libapriltag finds at the pitch board.json states, region
// outlines where board.json puts the regions, and a scale bar 100 mm long.
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/geometry/board.h"
#include "calib/geometry/board_print.h"
#include "calib/geometry/detect.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;
using testing::RunGonio;

constexpr double kDpi = 300;
constexpr double kPxPerMm = kDpi / 25.4;

// The PDF's first page as 8-bit grey at kDpi, rasterised by pdftoppm.
cv::Mat Rasterise(const fs::path& pdf, const fs::path& dir) {
  const fs::path stem = dir / "page";
  const std::string cmd = "pdftoppm -r " + std::to_string(static_cast<int>(kDpi)) +
                          " -gray -singlefile " + pdf.string() + " " + stem.string();
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return cv::imread(stem.string() + ".pgm", cv::IMREAD_GRAYSCALE);
}

// pixel = A p_in_board_mm + t, least squares over every detected tag corner.
struct BoardToPixel {
  Eigen::Matrix2d A;
  Eigen::Vector2d t;
  Eigen::Vector2d operator()(const Eigen::Vector2d& p) const { return A * p + t; }
  Eigen::Vector2d Inverse(const Eigen::Vector2d& px) const { return A.inverse() * (px - t); }
};

BoardToPixel FitAffine(const Board& board, const std::vector<TagDetection>& tags) {
  std::vector<Eigen::Vector2d> from, to;
  for (const auto& tag : tags) {
    const int k = board.TagIndex(tag.id);
    if (k < 0) continue;
    for (int c = 0; c < 4; ++c) {
      from.push_back(board.Points()[Board::TagPointIndex(k, c)].head<2>() * 1000.0);
      to.push_back(tag.corners[c]);
    }
  }
  Eigen::MatrixXd M(2 * from.size(), 6);
  Eigen::VectorXd b(2 * from.size());
  M.setZero();
  for (size_t i = 0; i < from.size(); ++i) {
    M.row(2 * i) << from[i].x(), from[i].y(), 0, 0, 1, 0;
    M.row(2 * i + 1) << 0, 0, from[i].x(), from[i].y(), 0, 1;
    b.segment<2>(2 * i) = to[i];
  }
  const Eigen::VectorXd x = M.colPivHouseholderQr().solve(b);
  BoardToPixel f;
  f.A << x[0], x[1], x[2], x[3];
  f.t << x[4], x[5];
  return f;
}

// Darkness-weighted centre of the dark line crossing the segment from `a` to `b` (pixels).
double LineCentre(const cv::Mat& grey, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const int n = static_cast<int>((b - a).norm() * 4);
  double sum_w = 0, sum_ws = 0;
  for (int i = 0; i <= n; ++i) {
    const double s = static_cast<double>(i) / n;
    const Eigen::Vector2d p = a + s * (b - a);
    // Bilinear interpolation between the four neighbouring pixel centres.
    const int x = static_cast<int>(std::floor(p.x())), y = static_cast<int>(std::floor(p.y()));
    const double fx = p.x() - x, fy = p.y() - y;
    const double v =
        (1 - fy) * ((1 - fx) * grey.at<uint8_t>(y, x) + fx * grey.at<uint8_t>(y, x + 1)) +
        fy * ((1 - fx) * grey.at<uint8_t>(y + 1, x) + fx * grey.at<uint8_t>(y + 1, x + 1));
    const double w = std::max(0.0, 200.0 - v);
    sum_w += w;
    sum_ws += w * s;
  }
  EXPECT_GT(sum_w, 0) << "no line found";
  return sum_w > 0 ? sum_ws / sum_w : 0.5;
}

// Measured position (board frame, mm) of the outline drawn kRegionOutlineGapMm outside the
// edge of `region` (xmin, ymin, xmax, ymax in mm) given by `edge` (0..3), scanned at 5 places.
double MeasureEdge(const cv::Mat& grey, const BoardToPixel& f, const std::array<double, 4>& r,
                   int edge) {
  const bool vertical = edge == 0 || edge == 2;  // xmin or xmax
  const double expected = r[edge] + (edge < 2 ? -1 : 1) * kRegionOutlineGapMm;
  double sum = 0;
  for (int i = 1; i <= 5; ++i) {
    const double along = vertical ? r[1] + (r[3] - r[1]) * i / 6.0 : r[0] + (r[2] - r[0]) * i / 6;
    auto at = [&](double across) {
      return vertical ? Eigen::Vector2d(across, along) : Eigen::Vector2d(along, across);
    };
    const double lo = expected - 1.5, hi = expected + 1.5;
    const double s = LineCentre(grey, f(at(lo)), f(at(hi)));
    const Eigen::Vector2d p = f.Inverse(f(at(lo)) + s * (f(at(hi)) - f(at(lo))));
    sum += vertical ? p.x() : p.y();
  }
  return sum / 5 + (edge < 2 ? 1 : -1) * kRegionOutlineGapMm;  // back to the region's edge
}

std::array<double, 4> RegionMm(const std::vector<Eigen::Vector2d>& poly) {
  std::array<double, 4> r = {1e9, 1e9, -1e9, -1e9};
  for (const auto& p : poly) {
    r[0] = std::min(r[0], p.x() * 1000);
    r[1] = std::min(r[1], p.y() * 1000);
    r[2] = std::max(r[2], p.x() * 1000);
    r[3] = std::max(r[3], p.y() * 1000);
  }
  return r;
}

// Length (mm) of the longest solid dark run in the rows below `y0`: the scale bar. Partly
// covered pixels at its ends count by their darkness (area coverage).
double ScaleBarLengthMm(const cv::Mat& grey, int y0) {
  double best = 0;
  for (int y = y0; y < grey.rows; ++y) {
    const uint8_t* row = grey.ptr<uint8_t>(y);
    for (int x = 0; x < grey.cols;) {
      if (row[x] > 64) {
        ++x;
        continue;
      }
      int end = x;
      while (end < grey.cols && row[end] <= 64) ++end;
      double length = end - x;
      if (x > 0) length += (255.0 - row[x - 1]) / 255.0;
      if (end < grey.cols) length += (255.0 - row[end]) / 255.0;
      best = std::max(best, length);
      x = end;
    }
  }
  return best / kPxPerMm;
}

struct Case {
  std::string args, family;
};

class BoardPrint : public ::testing::TestWithParam<Case> {};

TEST_P(BoardPrint, RasterisedPdfMatchesBoardJsonWithin0p2Percent) {
  testing::TempDir dir;
  const fs::path out = dir.path() / "board";
  const auto r = RunGonio("board --out " + out.string() + " " + GetParam().args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"board.pdf", "board.svg", "board.png", "board.json"}) {
    EXPECT_TRUE(fs::exists(out / f)) << f;
  }
  const Board board = Board::Read(out / "board.json");
  EXPECT_EQ(board.family(), GetParam().family);
  const int tags = static_cast<int>(
      std::count_if(board.ids().begin(), board.ids().end(), [](int id) { return id >= 0; }));
  EXPECT_EQ(tags, 2 * (board.columns() + board.rows()) - 4);

  const cv::Mat grey = Rasterise(out / "board.pdf", dir.path());
  ASSERT_FALSE(grey.empty());
  AprilTagOptions opt;
  opt.family = board.family();
  const auto found = DetectAprilTags(grey, opt);
  int on_board = 0;
  for (const auto& t : found) on_board += board.TagIndex(t.id) >= 0;
  EXPECT_EQ(on_board, tags);
  EXPECT_EQ(static_cast<int>(found.size()), tags);

  // Scale: the tags' corners map board millimetres to pixels at exactly kDpi, unrotated.
  const BoardToPixel f = FitAffine(board, found);
  EXPECT_NEAR(f.A(0, 0) / kPxPerMm, 1.0, 0.002);
  EXPECT_NEAR(f.A(1, 1) / kPxPerMm, 1.0, 0.002);
  EXPECT_NEAR(f.A(0, 1) / kPxPerMm, 0.0, 0.002);
  EXPECT_NEAR(f.A(1, 0) / kPxPerMm, 0.0, 0.002);

  // Pitch: tag centres of neighbours along the top row, in printed millimetres.
  double pitch_sum = 0;
  int pairs = 0;
  for (const auto& a : found) {
    for (const auto& b : found) {
      const int ka = board.TagIndex(a.id), kb = board.TagIndex(b.id);
      if (kb != ka + 1 || ka / board.columns() != kb / board.columns()) continue;
      Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cb = Eigen::Vector2d::Zero();
      for (int c = 0; c < 4; ++c) {
        ca += a.corners[c] / 4;
        cb += b.corners[c] / 4;
      }
      pitch_sum += (cb - ca).norm() / kPxPerMm;
      ++pairs;
    }
  }
  ASSERT_GT(pairs, 2);
  const double pitch_mm = board.pitch() * 1000;
  EXPECT_NEAR(pitch_sum / pairs, pitch_mm, 0.002 * pitch_mm);
  std::cout << "pitch " << pitch_sum / pairs << " mm (board.json " << pitch_mm << ")\n";

  // Regions: each edge's outline, found in the raster, against board.json.
  for (const auto* poly : {&board.sample_region(), &board.white_region()}) {
    const auto region = RegionMm(*poly);
    const double w = region[2] - region[0], h = region[3] - region[1];
    for (int edge = 0; edge < 4; ++edge) {
      const double measured = MeasureEdge(grey, f, region, edge);
      // 0.2% of the edge's distance from the board origin or of the region's size, the larger.
      const double tol = 0.002 * std::max(std::abs(region[edge]), edge % 2 == 0 ? w : h);
      EXPECT_NEAR(measured, region[edge], tol) << "edge " << edge;
      std::cout << "region edge " << edge << ": " << measured - region[edge] << " mm off\n";
    }
  }

  // Scale bar: below the lowest tag, 100 mm at the rasterised scale.
  const double lowest_tag_px = f(Eigen::Vector2d(0, board.rows() * board.pitch() * 1000)).y();
  const double bar_mm = ScaleBarLengthMm(grey, static_cast<int>(lowest_tag_px));
  EXPECT_NEAR(bar_mm, 100.0, 0.2);
  std::cout << "scale bar " << bar_mm << " mm\n";

  // The vector files carry the paper's physical size.
  std::stringstream svg;
  svg << std::ifstream(out / "board.svg").rdbuf();
  const cv::Mat png = cv::imread((out / "board.png").string(), cv::IMREAD_UNCHANGED);
  const PaperSize paper =
      ParsePaper(GetParam().args.find("letter") != std::string::npos ? "letter" : "a4", "paper");
  EXPECT_NE(svg.str().find(fmt::format("width=\"{}mm\"", paper.width_mm)), std::string::npos)
      << svg.str().substr(0, 300);
  EXPECT_EQ(png.cols, std::lround(paper.width_mm * 150 / 25.4));
  EXPECT_EQ(png.rows, std::lround(paper.height_mm * 150 / 25.4));
}

INSTANTIATE_TEST_SUITE_P(
    Boards, BoardPrint,
    ::testing::Values(Case{"--paper a4 --tag-size 30 --dpi 150", "tag36h11"},
                      Case{"--paper letter --tag-size 18 --family tagStandard41h12 "
                           "--id-offset 40 --dpi 150",
                           "tagStandard41h12"}));

TEST(BoardPrintCli, IdOffsetShiftsEveryId) {
  testing::TempDir dir;
  ASSERT_EQ(RunGonio("board --paper a4 --tag-size 30 --dpi 50 --out " + (dir.path() / "a").string())
                .exit_code,
            0);
  ASSERT_EQ(RunGonio("board --paper a4 --tag-size 30 --dpi 50 --id-offset 100 --out " +
                     (dir.path() / "b").string())
                .exit_code,
            0);
  const Board a = Board::Read(dir.path() / "a" / "board.json");
  const Board b = Board::Read(dir.path() / "b" / "board.json");
  ASSERT_EQ(a.ids().size(), b.ids().size());
  for (size_t k = 0; k < a.ids().size(); ++k) {
    EXPECT_EQ(b.ids()[k], a.ids()[k] < 0 ? -1 : a.ids()[k] + 100);
  }
}

TEST(BoardPrintCli, BadInputExitsTwoWithOneLineAndWritesNothing) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--paper 90x90 --tag-size 30", "--paper"},
      {"--paper a4 --tag-size 80", "--paper"},
      {"--paper a4 --family tag99h1", "--family"},
      {"--paper a4 --tag-size 30 --columns 9", "--columns"},
      {"--paper a4 --tag-size 30 --pitch 31", "--pitch"},
      {"--paper a4 --tag-size 30 --pitch 37.51", "--pitch"},  // no lattice mrcal can use
      {"--paper a4 --id-offset 580", "--id-offset"},
      {"--paper b5", "--paper"},
      {"--paper a4 --tag-size -3", "--tag-size"},
  };
  for (const auto& [args, names] : cases) {
    testing::TempDir dir;
    const fs::path out = dir.path() / "board";
    const auto r = RunGonio("board " + args + " --out " + out.string());
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(testing::MessageLines(r.err), 1) << args << ": " << r.err;
    EXPECT_NE(r.err.find(names), std::string::npos) << args << ": " << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
}

}  // namespace
}  // namespace gonio
