// The radiance of a textured sample (texture.h) under one lamp: the board renderer and the
// rectified-view renderer (rectified_views.h) both shade through this class, so their pixels
// agree on the same surface.
#pragma once

#include <array>
#include <filesystem>
#include <functional>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "data_synth/scene.h"
#include "data_synth/texture.h"
#include "reflectance/angles.h"

namespace gonio::synth {

using Rgb = std::array<double, 3>;

class TexturedShader {
 public:
  // The scene's texture over its sample region, shaded with material.model (the texture sets
  // its albedo per channel and its roughness per point). InputError for a model that cannot
  // be textured.
  explicit TexturedShader(const Scene& scene);

  // Radiance (R, G, B) of the sample at board point p (on its top plane) seen from
  // camera_in_board, lit by a point lamp at lamp_in_board of intensity I (E = I cos / d^2
  // about the point's own normal), or for a distant lamp by `irradiance` from direction
  // to_lamp (unit). Zero where the relief faces away from the lamp or the camera.
  // NumericalError when the model has no valid value there.
  Rgb Point(const Eigen::Vector3d& p, const Eigen::Vector3d& camera_in_board,
            const Eigen::Vector3d& lamp_in_board, double intensity) const;
  Rgb Distant(const Eigen::Vector3d& p, const Eigen::Vector3d& camera_in_board,
              const Eigen::Vector3d& to_lamp, double irradiance) const;

  const Texture& texture() const { return texture_; }

 private:
  Rgb Shade(const TexturePoint& t, const Eigen::Vector3d& n, const Eigen::Vector3d& p,
            const Eigen::Vector3d& l, double e, const Eigen::Vector3d& camera_in_board) const;
  std::string model_;
  Texture texture_;
  std::function<double(const double*, const Angles<double>&)> eval_;
};

// The truth maps of the scene's texture over `region` (board frame [xmin, ymin, xmax, ymax];
// the sample region for a session) at `texel` metres, written into `dir` as 32-bit float TIFFs
// (truth_albedo.tiff RGB, truth_normal.tiff tangent-space x, y, z, truth_height.tiff metres,
// truth_roughness.tiff, truth_materials.tiff material index); returns truth.json's "texture" block
// (the spec, the grid and the files; docs/formats.md).
nlohmann::json WriteTextureTruth(const Scene& scene, const std::array<double, 4>& region,
                                 double texel, const std::filesystem::path& dir);

}  // namespace gonio::synth
