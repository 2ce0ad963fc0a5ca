#include "data_synth/tag_board.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "common/error.h"

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/common/image_u8.h>
#include <apriltag/tag36h11.h>
}

namespace gonio::synth {

TagBoard::TagBoard(const BoardSpec& spec) : spec_(spec), ids_(spec.ResolvedIds()) {
  extent_ = spec_.Extent();
  apriltag_family_t* family = tag36h11_create();
  bits_ = family->width_at_border;
  cell_ = spec_.tag_size / bits_;
  // apriltag_to_image draws the tag with its white quiet zone; the black-border square starts
  // `offset` cells in.
  const int offset = (family->total_width - family->width_at_border) / 2;
  black_.resize(ids_.size());
  for (size_t k = 0; k < ids_.size(); ++k) {
    if (ids_[k] < 0) continue;
    if (static_cast<uint32_t>(ids_[k]) >= family->ncodes) {
      tag36h11_destroy(family);
      throw InputError("board.ids: tag36h11 has no id " + std::to_string(ids_[k]));
    }
    image_u8_t* im = apriltag_to_image(family, ids_[k]);
    auto& bits = black_[k];
    bits.resize(bits_ * bits_);
    for (int v = 0; v < bits_; ++v) {
      for (int u = 0; u < bits_; ++u) {
        bits[v * bits_ + u] = im->buf[(v + offset) * im->stride + (u + offset)] < 128;
      }
    }
    // Debian's libapriltag exports apriltag_to_image but not image_u8_destroy; the image is
    // two calloc'ed blocks (apriltag/common/image_u8.c), freed as image_u8_destroy does.
    free(im->buf);
    free(im);
  }
  tag36h11_destroy(family);
}

int TagBoard::TagAt(double x, double y, int* cell_x, int* cell_y) const {
  if (spec_.columns <= 0 || spec_.rows <= 0) return -1;
  const int col = static_cast<int>(std::floor(x / spec_.pitch));
  const int row = static_cast<int>(std::floor(y / spec_.pitch));
  if (col < 0 || row < 0 || col >= spec_.columns || row >= spec_.rows) return -1;
  const int k = row * spec_.columns + col;
  if (ids_[k] < 0) return -1;
  const double u = x - col * spec_.pitch, v = y - row * spec_.pitch;
  if (u >= spec_.tag_size || v >= spec_.tag_size) return -1;
  *cell_x = std::min(bits_ - 1, static_cast<int>(u / cell_));
  *cell_y = std::min(bits_ - 1, static_cast<int>(v / cell_));
  return k;
}

Surface TagBoard::At(double x, double y) const {
  if (x < extent_[0] || y < extent_[1] || x >= extent_[2] || y >= extent_[3]) {
    return Surface::kBackground;
  }
  const auto& s = spec_.sample_region;
  if (x >= s[0] && x < s[2] && y >= s[1] && y < s[3]) return Surface::kSample;
  int cx = 0, cy = 0;
  const int k = TagAt(x, y, &cx, &cy);
  if (k >= 0 && black_[k][cy * bits_ + cx]) return Surface::kInk;
  return Surface::kPaper;
}

bool TagBoard::Uniform(double x0, double y0, double x1, double y1, Surface* surface) const {
  // Board edge and region edges.
  for (const auto* r : {&extent_, &spec_.sample_region}) {
    const auto& e = *r;
    const bool overlaps = x1 >= e[0] && x0 < e[2] && y1 >= e[1] && y0 < e[3];
    const bool inside = x0 >= e[0] && x1 < e[2] && y0 >= e[1] && y1 < e[3];
    if (overlaps && !inside) return false;
  }
  *surface = At(x0, y0);
  if (*surface == Surface::kBackground || *surface == Surface::kSample) return true;
  if (spec_.columns <= 0 || spec_.rows <= 0) return true;
  // Tags whose square the box may touch.
  const int c0 = std::max(0, static_cast<int>(std::floor(x0 / spec_.pitch)));
  const int c1 = std::min(spec_.columns - 1, static_cast<int>(std::floor(x1 / spec_.pitch)));
  const int r0 = std::max(0, static_cast<int>(std::floor(y0 / spec_.pitch)));
  const int r1 = std::min(spec_.rows - 1, static_cast<int>(std::floor(y1 / spec_.pitch)));
  for (int row = r0; row <= r1; ++row) {
    for (int col = c0; col <= c1; ++col) {
      const int k = row * spec_.columns + col;
      if (ids_[k] < 0) continue;
      const double tx = col * spec_.pitch, ty = row * spec_.pitch;
      const double tx1 = tx + spec_.tag_size, ty1 = ty + spec_.tag_size;
      if (x1 < tx || x0 >= tx1 || y1 < ty || y0 >= ty1) continue;      // no overlap
      if (x0 < tx || x1 >= tx1 || y0 < ty || y1 >= ty1) return false;  // crosses the border
      // Inside this tag: uniform when inside one bit cell.
      const double u0 = (x0 - tx) / cell_, u1 = (x1 - tx) / cell_;
      const double v0 = (y0 - ty) / cell_, v1 = (y1 - ty) / cell_;
      if (std::floor(u0) != std::floor(u1) || std::floor(v0) != std::floor(v1)) return false;
    }
  }
  return true;
}

std::vector<TagBoard::TagCorners> TagBoard::Corners() const {
  std::vector<TagCorners> out;
  for (int row = 0; row < spec_.rows; ++row) {
    for (int col = 0; col < spec_.columns; ++col) {
      const int id = ids_[row * spec_.columns + col];
      if (id < 0) continue;
      const double x = col * spec_.pitch, y = row * spec_.pitch, s = spec_.tag_size;
      out.push_back({id,
                     {Eigen::Vector3d(x, y, 0), Eigen::Vector3d(x + s, y, 0),
                      Eigen::Vector3d(x + s, y + s, 0), Eigen::Vector3d(x, y + s, 0)}});
    }
  }
  return out;
}

nlohmann::json TagBoard::BoardJson() const {
  auto polygon = [](const std::array<double, 4>& r) {
    return nlohmann::json::array({{r[0], r[1]}, {r[2], r[1]}, {r[2], r[3]}, {r[0], r[3]}});
  };
  nlohmann::json j = {{"type", "apriltag-grid"},
                      {"family", spec_.family},
                      {"tag_size", spec_.tag_size},
                      {"pitch", spec_.pitch},
                      {"columns", spec_.columns},
                      {"rows", spec_.rows},
                      {"ids", ids_},
                      {"sample_region", polygon(spec_.sample_region)},
                      {"white_region", polygon(spec_.white_region)}};
  // The user's measurement of a raised sample's thickness (docs/formats.md).
  if (spec_.sample_height > 0) j["sample_height_m"] = spec_.sample_height;
  return j;
}

}  // namespace gonio::synth
