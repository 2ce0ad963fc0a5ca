#include "data_synth/textured_shading.h"

#include <cmath>
#include <string>

#include <opencv2/core.hpp>

#include "common/error.h"
#include "common/float_tiff.h"
#include "common/math.h"
#include "data_synth/shading.h"
#include "reflectance/registry.h"

namespace fs = std::filesystem;

namespace gonio::synth {
namespace {

const ModelInfo& TexturedModel(const Scene& scene) {
  const ModelInfo& info = FindModel(scene.material.model);
  if (info.params.empty() || !info.params[0].per_channel || info.params.size() > 2) {
    throw InputError("texture: model " + scene.material.model +
                     " cannot be textured (needs a per-channel albedo and at most a roughness)");
  }
  return info;
}

double RoughnessBound(const ModelInfo& info, bool high) {
  if (info.params.size() < 2) return 0.0;
  return high ? info.params[1].max : info.params[1].min;
}

}  // namespace

TexturedShader::TexturedShader(const Scene& scene)
    : model_(scene.material.model),
      texture_(scene.texture, scene.board.sample_region,
               RoughnessBound(TexturedModel(scene), false),
               RoughnessBound(TexturedModel(scene), true)) {
  VisitModel(model_, [&](auto tag) {
    using M = typename decltype(tag)::type;
    eval_ = [](const double* params, const Angles<double>& a) { return M::Evaluate(params, a); };
  });
}

Rgb TexturedShader::Shade(const TexturePoint& t, const Eigen::Vector3d& n, const Eigen::Vector3d& p,
                          const Eigen::Vector3d& l, double e,
                          const Eigen::Vector3d& camera_in_board) const {
  const Eigen::Vector3d v = (camera_in_board - p).normalized();
  if (!(e > 0) || !(n.dot(v) > 0)) return {0, 0, 0};
  const Angles<double> a = LocalAngles(n, l, v);
  Rgb out;
  for (int c = 0; c < 3; ++c) {
    const double params[2] = {t.albedo[c], t.roughness};
    const double f = eval_(params, a);
    if (!std::isfinite(f) || f < 0) {
      throw NumericalError("texture: model " + model_ +
                           " has no valid value at theta_i=" + std::to_string(RadToDeg(a.theta_i)) +
                           " theta_r=" + std::to_string(RadToDeg(a.theta_r)) + " deg");
    }
    out[c] = f * e;
  }
  return out;
}

Rgb TexturedShader::Point(const Eigen::Vector3d& p, const Eigen::Vector3d& camera_in_board,
                          const Eigen::Vector3d& lamp_in_board, double intensity) const {
  const TexturePoint t = texture_.At(p.x(), p.y());
  const Eigen::Vector3d n = t.Normal();
  Eigen::Vector3d l;
  const double e = PointIrradiance(p, n, lamp_in_board, intensity, &l);
  return Shade(t, n, p, l, e, camera_in_board);
}

Rgb TexturedShader::Distant(const Eigen::Vector3d& p, const Eigen::Vector3d& camera_in_board,
                            const Eigen::Vector3d& to_lamp, double irradiance) const {
  const TexturePoint t = texture_.At(p.x(), p.y());
  const Eigen::Vector3d n = t.Normal();
  return Shade(t, n, p, to_lamp, irradiance * std::max(0.0, n.dot(to_lamp)), camera_in_board);
}

nlohmann::json WriteTextureTruth(const Scene& scene, const std::array<double, 4>& r, double t,
                                 const fs::path& dir) {
  const TexturedShader shader(scene);
  const Texture& tex = shader.texture();
  const int w = std::max(1, static_cast<int>(std::lround((r[2] - r[0]) / t)));
  const int h = std::max(1, static_cast<int>(std::lround((r[3] - r[1]) / t)));
  cv::Mat albedo(h, w, CV_32FC3), normal(h, w, CV_32FC3), height(h, w, CV_32F),
      roughness(h, w, CV_32F), material(h, w, CV_32F);
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const TexturePoint p = tex.At(r[0] + (i + 0.5) * t, r[1] + (j + 0.5) * t);
      albedo.at<cv::Vec3f>(j, i) = cv::Vec3f(p.albedo[0], p.albedo[1], p.albedo[2]);
      // Tangent space: X = board +x, Y = board -y (up in the map), Z = outward.
      const Eigen::Vector3d n = Eigen::Vector3d(-p.slope.x(), p.slope.y(), 1.0).normalized();
      normal.at<cv::Vec3f>(j, i) = cv::Vec3f(n.x(), n.y(), n.z());
      height.at<float>(j, i) = static_cast<float>(p.height);
      roughness.at<float>(j, i) = static_cast<float>(p.roughness);
      material.at<float>(j, i) = static_cast<float>(p.material);
    }
  }
  WriteFloatTiff(dir / "truth_albedo.tiff", albedo);
  WriteFloatTiff(dir / "truth_normal.tiff", normal);
  WriteFloatTiff(dir / "truth_height.tiff", height);
  WriteFloatTiff(dir / "truth_roughness.tiff", roughness);
  WriteFloatTiff(dir / "truth_materials.tiff", material);
  nlohmann::json materials = nlohmann::json::array();
  for (const auto& m : scene.texture.materials) {
    materials.push_back({{"albedo", m.albedo}, {"roughness", m.roughness}});
  }
  return {{"model", scene.material.model},
          {"materials", materials},
          {"grid",
           {{"texel_m", t},
            {"width", w},
            {"height", h},
            {"first_texel_centre_in_board", {r[0] + 0.5 * t, r[1] + 0.5 * t}},
            {"rows", "row j at board y = first + j texel (board +y down the map)"}}},
          {"files",
           {{"albedo", "truth_albedo.tiff"},
            {"normal", "truth_normal.tiff"},
            {"height", "truth_height.tiff"},
            {"roughness", "truth_roughness.tiff"},
            {"materials", "truth_materials.tiff"}}},
          {"normal_convention",
           "tangent space, stored (x, y, z): X = board +x (map right), Y = board -y (map up), Z = "
           "outward normal (OpenGL / MikkTSpace, as Blender and MaterialX read normal maps)"},
          {"height_unit", "m, along the outward normal"},
          {"shading",
           "bump map: the surface stays on the sample plane, each point shaded with its relief "
           "normal; albedo and roughness set the model's parameters per point"}};
}

}  // namespace gonio::synth
