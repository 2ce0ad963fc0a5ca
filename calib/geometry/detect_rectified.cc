// The board-guided searches of calib/geometry/detect.cc: where the board's layout predicts a
// tag that no pass found (docs/calibration.md "Tag detection").
#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/geometry/detect_internal.h"

namespace gonio::detect_internal {
namespace {

Eigen::Vector2d BoardCentre(const Board& board, int k) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i = 0; i < 4; ++i) c += 0.25 * board.Points()[Board::TagPointIndex(k, i)];
  return c.head<2>();
}

cv::Point2d Apply(const cv::Matx33d& h, const cv::Point2d& p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1.0);
  return {q[0] / q[2], q[1] / q[2]};
}

// Bilinear grey level at (x, y), gonio pixels (the caller keeps (x, y) inside the image).
double Sample(const cv::Mat& grey, double x, double y) {
  const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, grey.cols - 2);
  const int y0 = std::clamp(static_cast<int>(std::floor(y)), 0, grey.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const uint8_t* r0 = grey.ptr<uint8_t>(y0);
  const uint8_t* r1 = grey.ptr<uint8_t>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
         fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}

// The quad's edges fitted again in the original image, as libapriltag refines a quad found on a
// decimated image (docs/calibration.md "Tag detection"): along each edge, the dark-to-bright
// step across it (bright-to-dark for families whose border is reversed) within +-1 px (the
// gradient-weighted mean offset), then a weighted line through those points; the corners are the
// lines' intersections. The quad is left as it is when an edge has too few samples or two lines are
// (nearly) parallel.
std::array<Eigen::Vector2d, 4> RefineEdges(const cv::Mat& grey, std::array<Eigen::Vector2d, 4> q,
                                           bool reversed_border) {
  const Eigen::Vector2d centre = 0.25 * (q[0] + q[1] + q[2] + q[3]);
  std::array<Eigen::Vector3d, 4> lines;  // a x + b y = c, (a, b) unit
  const double range = 1.0, span = 1.0;
  for (int e = 0; e < 4; ++e) {
    const Eigen::Vector2d a = q[e], b = q[(e + 1) % 4];
    Eigen::Vector2d normal(b.y() - a.y(), a.x() - b.x());
    normal.normalize();
    if (normal.dot(0.5 * (a + b) - centre) < 0) normal = -normal;  // outward: to the white
    const int samples = std::max(8, static_cast<int>((b - a).norm()));
    double sw = 0;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    std::vector<std::pair<Eigen::Vector2d, double>> points;
    for (int s = 0; s < samples; ++s) {
      const Eigen::Vector2d p0 = a + (b - a) * ((s + 1.0) / (samples + 1));
      double m = 0, w = 0;
      for (double n = -range; n <= range + 1e-9; n += 0.25) {
        const Eigen::Vector2d hi = p0 + (n + span) * normal, lo = p0 + (n - span) * normal;
        if (std::min({hi.x(), hi.y(), lo.x(), lo.y()}) < 0 ||
            std::max(hi.x(), lo.x()) > grey.cols - 1 || std::max(hi.y(), lo.y()) > grey.rows - 1) {
          continue;
        }
        const double g = (reversed_border ? -1 : 1) *
                         (Sample(grey, hi.x(), hi.y()) - Sample(grey, lo.x(), lo.y()));
        if (g <= 0) continue;
        m += g * n;
        w += g;
      }
      if (w <= 0) continue;
      points.push_back({p0 + (m / w) * normal, w});
      mean += w * points.back().first;
      sw += w;
    }
    if (points.size() < 4) return q;
    mean /= sw;
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& [p, w] : points) cov += w * (p - mean) * (p - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Eigen::Vector2d n = eig.eigenvectors().col(0);  // least spread: the line's normal
    lines[e] = Eigen::Vector3d(n.x(), n.y(), n.dot(mean));
  }
  std::array<Eigen::Vector2d, 4> out;
  for (int c = 0; c < 4; ++c) {
    // Corner c joins edge c-1 (from corner c-1 to c) and edge c.
    const Eigen::Vector3d& l1 = lines[(c + 3) % 4];
    const Eigen::Vector3d& l2 = lines[c];
    Eigen::Matrix2d m;
    m << l1.x(), l1.y(), l2.x(), l2.y();
    if (std::abs(m.determinant()) < 1e-3) return q;
    out[c] = m.inverse() * Eigen::Vector2d(l1.z(), l2.z());
    // A refit that moves a corner by more than the search could explain (+-1 px across each
    // edge, times 3 at a 20 deg corner) followed something else: keep the quad.
    if (!out[c].allFinite() || (out[c] - q[c]).norm() > 3.0) return q;
  }
  return out;
}

}  // namespace

std::vector<PredictedTag> PredictMissingTags(const Board& board,
                                             const std::vector<TagDetection>& found,
                                             const cv::Size& size) {
  std::vector<int> found_k;
  for (const auto& t : found) found_k.push_back(board.TagIndex(t.id));
  std::vector<PredictedTag> out;
  if (found.empty()) return out;
  for (size_t k = 0; k < board.ids().size(); ++k) {
    if (board.ids()[k] < 0 || std::count(found_k.begin(), found_k.end(), k) > 0) continue;
    const Eigen::Vector2d centre = BoardCentre(board, static_cast<int>(k));
    std::vector<size_t> nearest(found.size());
    for (size_t i = 0; i < nearest.size(); ++i) nearest[i] = i;
    std::sort(nearest.begin(), nearest.end(), [&](size_t a, size_t b) {
      return (BoardCentre(board, found_k[a]) - centre).norm() <
             (BoardCentre(board, found_k[b]) - centre).norm();
    });
    nearest.resize(std::min<size_t>(nearest.size(), 4));
    std::vector<cv::Point2d> from, to;
    for (size_t i : nearest) {
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector3d& p = board.Points()[Board::TagPointIndex(found_k[i], c)];
        from.emplace_back(p.x(), p.y());
        to.emplace_back(found[i].corners[c].x(), found[i].corners[c].y());
      }
    }
    const cv::Mat h = cv::findHomography(from, to, 0);
    if (h.empty()) continue;
    PredictedTag t;
    t.k = static_cast<int>(k);
    t.image_from_board = cv::Matx33d(h);
    t.inside = true;
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector3d& p = board.Points()[Board::TagPointIndex(t.k, c)];
      t.corners[c] = Apply(t.image_from_board, {p.x(), p.y()});
      const cv::Point2d& q = t.corners[c];
      t.inside = t.inside && std::isfinite(q.x) && std::isfinite(q.y) && q.x >= 0 && q.y >= 0 &&
                 q.x <= size.width - 1 && q.y <= size.height - 1;
    }
    out.push_back(t);
  }
  return out;
}

std::vector<TagDetection> DetectRectified(const cv::Mat& grey, const Board& board,
                                          const std::vector<PredictedTag>& missing,
                                          AprilTagDetector* detector) {
  const apriltag_family_t& family = detector->family();
  // The view: kCell px per bit cell, the tag's black square plus its white quiet zone and half
  // a cell beyond it (the prediction's error), so a neighbour's black edge stays outside.
  constexpr double kCell = 8;
  const double cell = board.tag_size() / family.width_at_border;
  const double margin = 0.5 * (family.total_width - family.width_at_border) + 0.5;
  const int n = static_cast<int>(std::lround((family.width_at_border + 2 * margin) * kCell));
  std::vector<TagDetection> out;
  for (const PredictedTag& p : missing) {
    const Eigen::Vector3d& top_left = board.Points()[Board::TagPointIndex(p.k, 3)];
    // patch = (board - top_left) / cell * kCell + margin * kCell (board y points down, as
    // the patch's: the tag is seen upright, not mirrored).
    const double s = kCell / cell, o = margin * kCell;
    const cv::Matx33d patch_from_board(s, 0, o - s * top_left.x(), 0, s, o - s * top_left.y(), 0, 0,
                                       1);
    const cv::Matx33d image_from_patch = p.image_from_board * patch_from_board.inv();
    cv::Mat patch;
    cv::warpPerspective(grey, patch, cv::Mat(image_from_patch), cv::Size(n, n),
                        cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
    for (const TagDetection& d : detector->Detect(patch, cv::Rect(0, 0, n, n), 1.0, true)) {
      if (d.id != board.ids()[p.k]) continue;
      // Every corner within a cell of where the layout puts it: the right id at the right
      // place, in the right orientation.
      bool placed = true;
      TagDetection t = d;
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector3d& b = board.Points()[Board::TagPointIndex(p.k, c)];
        const cv::Point2d expected = Apply(patch_from_board, {b.x(), b.y()});
        const cv::Point2d q(d.corners[c].x(), d.corners[c].y());
        placed = placed && cv::norm(q - expected) <= kCell;
        const cv::Point2d in_image = Apply(image_from_patch, q);
        t.corners[c] = Eigen::Vector2d(in_image.x, in_image.y);
      }
      const bool finite = std::all_of(t.corners.begin(), t.corners.end(),
                                      [](const Eigen::Vector2d& c) { return c.allFinite(); });
      if (!placed || !finite) continue;
      t.corners = RefineEdges(grey, t.corners, family.reversed_border);
      out.push_back(t);
    }
  }
  return out;
}

}  // namespace gonio::detect_internal
