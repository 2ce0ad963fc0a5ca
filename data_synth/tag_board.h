// The printed board as a reflectance map: which material lies at a board point (white paper,
// black ink of a tag bit, the sample, or nothing), from libapriltag's own tag36h11 bitmaps.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "data_synth/scene.h"

namespace gonio::synth {

enum class Surface : int { kBackground = 0, kPaper = 1, kInk = 2, kSample = 3 };

class TagBoard {
 public:
  explicit TagBoard(const BoardSpec& spec);

  Surface At(double x, double y) const;
  // True when the axis-aligned box [x0, x1] x [y0, y1] lies on one surface (then *surface
  // says which): no tag bit edge, region edge or board edge crosses it.
  bool Uniform(double x0, double y0, double x1, double y1, Surface* surface) const;

  // Black-border corners of every tag in the board frame, in the order top-left, top-right,
  // bottom-right, bottom-left (board x right, y down).
  struct TagCorners {
    int id;
    std::array<Eigen::Vector3d, 4> corners;
  };
  std::vector<TagCorners> Corners() const;

  // board.json (docs/formats.md).
  nlohmann::json BoardJson() const;

 private:
  // Index into tags_ of the tag whose square contains (x, y), or -1.
  int TagAt(double x, double y, int* cell_x, int* cell_y) const;
  BoardSpec spec_;
  std::vector<int> ids_;
  std::array<double, 4> extent_;
  double cell_;
  int bits_;  // cells across the black border (width_at_border, 8 for tag36h11)
  // Per grid position: bits_ x bits_ row-major, true = black; empty when no tag.
  std::vector<std::vector<bool>> black_;
};

}  // namespace gonio::synth
