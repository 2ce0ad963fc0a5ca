#include "estimation/sfs/sfs_pyramid.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace gonio::sfs_internal {
namespace {

// Extends u outside the mask by repeated neighbour averaging so bilinear upsampling near the
// contour has values on both sides.
void FillOutside(const cv::Mat& mask, cv::Mat* u, int rings) {
  cv::Mat known = mask.clone();
  for (int it = 0; it < rings; ++it) {
    cv::Mat next_known = known.clone();
    cv::Mat next = u->clone();
    for (int y = 0; y < u->rows; ++y) {
      for (int x = 0; x < u->cols; ++x) {
        if (known.at<uint8_t>(y, x)) continue;
        double sum = 0;
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= u->cols || yy >= u->rows) continue;
            if (known.at<uint8_t>(yy, xx)) {
              sum += u->at<double>(yy, xx);
              ++n;
            }
          }
        }
        if (n > 0) {
          next.at<double>(y, x) = sum / n;
          next_known.at<uint8_t>(y, x) = 255;
        }
      }
    }
    *u = next;
    known = next_known;
  }
}

}  // namespace

Level MakeLevel(const SfsProblem& pr, int scale) {
  Level lv;
  lv.scale = scale;
  lv.w = pr.radiance.cols / scale;
  lv.h = pr.radiance.rows / scale;
  lv.radiance = cv::Mat(lv.h, lv.w, CV_64F, cv::Scalar(0));
  lv.mask = cv::Mat(lv.h, lv.w, CV_8U, cv::Scalar(0));
  lv.rays.resize(static_cast<size_t>(lv.w) * lv.h);
  for (int y = 0; y < lv.h; ++y) {
    for (int x = 0; x < lv.w; ++x) {
      bool all = true;
      double sum = 0;
      for (int j = 0; j < scale && all; ++j) {
        for (int i = 0; i < scale; ++i) {
          const int fx = x * scale + i, fy = y * scale + j;
          if (!pr.mask.at<uint8_t>(fy, fx)) {
            all = false;
            break;
          }
          sum += pr.radiance.at<double>(fy, fx);
        }
      }
      if (all) {
        lv.mask.at<uint8_t>(y, x) = 255;
        lv.radiance.at<double>(y, x) = sum / (scale * scale);
      }
      // The block centre in full-resolution pixels (pixel centres at integers).
      const Eigen::Vector3d r = pr.camera.Unproject(
          Eigen::Vector2d(x * scale + 0.5 * (scale - 1), y * scale + 0.5 * (scale - 1)));
      lv.rays[static_cast<size_t>(y) * lv.w + x] = r / r.z();
    }
  }
  return lv;
}

bool Interior(const Level& lv, int x, int y) {
  return lv.In(x, y) && lv.In(x - 1, y) && lv.In(x + 1, y) && lv.In(x, y - 1) && lv.In(x, y + 1);
}

// Normal at a mask pixel from the depth map: central differences, one-sided where a neighbour
// is outside the mask. False when a direction has no neighbour at all.
bool NormalAt(const Level& lv, const cv::Mat& u, int x, int y, Eigen::Vector3d* n) {
  auto P = [&](int xx, int yy) { return lv.Ray(xx, yy) * std::exp(u.at<double>(yy, xx)); };
  Eigen::Vector3d tx, ty;
  if (lv.In(x - 1, y) && lv.In(x + 1, y)) {
    tx = P(x + 1, y) - P(x - 1, y);
  } else if (lv.In(x + 1, y)) {
    tx = P(x + 1, y) - P(x, y);
  } else if (lv.In(x - 1, y)) {
    tx = P(x, y) - P(x - 1, y);
  } else {
    return false;
  }
  if (lv.In(x, y - 1) && lv.In(x, y + 1)) {
    ty = P(x, y + 1) - P(x, y - 1);
  } else if (lv.In(x, y + 1)) {
    ty = P(x, y + 1) - P(x, y);
  } else if (lv.In(x, y - 1)) {
    ty = P(x, y) - P(x, y - 1);
  } else {
    return false;
  }
  const Eigen::Vector3d c = ty.cross(tx);
  if (!(c.norm() > 0)) return false;
  *n = c.normalized();
  return true;
}

// Convex initial surface from the mask's distance transform d: circular cross-sections
// perpendicular to the contour, h = sqrt(d (2a - d)), where a is the local radius (d at the
// medial-axis point reached by steepest ascent of d; exact for spheres and for surfaces of
// revolution seen side-on), with the anchor pixel (ax, ay) at depth `anchor`.
cv::Mat BalloonLogDepth(const Level& lv, double f_px, double anchor, int ax, int ay) {
  cv::Mat dt;
  cv::distanceTransform(lv.mask, dt, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::vector<std::pair<float, int>> order;
  for (int y = 0; y < lv.h; ++y) {
    for (int x = 0; x < lv.w; ++x) {
      if (lv.In(x, y)) order.push_back({dt.at<float>(y, x), y * lv.w + x});
    }
  }
  std::sort(order.begin(), order.end(), std::greater<>());
  cv::Mat a = dt.clone();
  for (const auto& [d, k] : order) {
    const int x = k % lv.w, y = k / lv.w;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if ((dx == 0 && dy == 0) || !lv.In(x + dx, y + dy)) continue;
        // Only moves nearly straight away from the contour (d grows ~1 per pixel step);
        // along the medial axis d changes slowly and nothing propagates.
        const double step = std::hypot(dx, dy);
        if (dt.at<float>(y + dy, x + dx) - d >= 0.7 * step) {
          a.at<float>(y, x) = std::max(a.at<float>(y, x), a.at<float>(y + dy, x + dx));
        }
      }
    }
  }
  auto height = [&](int x, int y) {
    const double r = a.at<float>(y, x), d = std::min<double>(dt.at<float>(y, x), r);
    return std::sqrt(std::max(0.0, d * (2 * r - d))) * lv.scale;  // full-res pixels
  };
  const double h_anchor = height(ax, ay);
  cv::Mat u(lv.h, lv.w, CV_64F, cv::Scalar(0));
  for (int y = 0; y < lv.h; ++y) {
    for (int x = 0; x < lv.w; ++x) {
      if (!lv.In(x, y)) continue;
      u.at<double>(y, x) = std::log(anchor + (h_anchor - height(x, y)) * anchor / f_px);
    }
  }
  return u;
}

cv::Mat Upsample(const Level& coarse, cv::Mat u, const Level& fine) {
  FillOutside(coarse.mask, &u, 3);
  const double r = static_cast<double>(coarse.scale) / fine.scale;
  cv::Mat out(fine.h, fine.w, CV_64F, cv::Scalar(0));
  for (int y = 0; y < fine.h; ++y) {
    for (int x = 0; x < fine.w; ++x) {
      if (!fine.In(x, y)) continue;
      const double cx = std::clamp((x + 0.5) / r - 0.5, 0.0, coarse.w - 1.0);
      const double cy = std::clamp((y + 0.5) / r - 0.5, 0.0, coarse.h - 1.0);
      const int x0 = std::min(static_cast<int>(cx), coarse.w - 2);
      const int y0 = std::min(static_cast<int>(cy), coarse.h - 2);
      const double fx = cx - x0, fy = cy - y0;
      out.at<double>(y, x) =
          (1 - fy) * ((1 - fx) * u.at<double>(y0, x0) + fx * u.at<double>(y0, x0 + 1)) +
          fy * ((1 - fx) * u.at<double>(y0 + 1, x0) + fx * u.at<double>(y0 + 1, x0 + 1));
    }
  }
  return out;
}

}  // namespace gonio::sfs_internal
