#include "data_synth/sfs_renderer.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/float_tiff.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/math.h"
#include "common/parallel.h"
#include "data_synth/photometric.h"
#include "data_synth/shading.h"

namespace fs = std::filesystem;

namespace gonio::synth {
namespace {

using json = nlohmann::json;

// An implicit surface in the camera frame: F > 0 outside, F < 0 inside, zero on the surface;
// rays are marched in depth z over [z_near, z_far].
class Shape {
 public:
  Shape(const SfsSpec& spec)
      : spec_(spec), kind_(spec.shape), centre_in_cam_(0, 0, spec.distance), s_(spec.size) {
    if (kind_ == SfsShape::kBumps) {
      // Gaussian bumps (and one dent) on a square patch facing the camera; heights and widths
      // relative to the patch half-width.
      bumps_ = {{0.0, 0.0, 0.35, 0.30},
                {0.55, 0.5, 0.18, 0.16},
                {-0.55, 0.45, 0.2, 0.18},
                {-0.5, -0.55, 0.16, 0.15},
                {0.5, -0.5, -0.12, 0.15}};
      z_near_ = centre_in_cam_.z() - 0.4 * s_;
      z_far_ = centre_in_cam_.z() + 0.2 * s_;
    } else {
      z_near_ = centre_in_cam_.z() - 1.05 * s_;
      z_far_ = centre_in_cam_.z() + 1.05 * s_;
    }
    half_height_ = kind_ == SfsShape::kVase ? 1.7 * s_ : s_;
  }

  double F(const Eigen::Vector3d& p) const {
    if (kind_ == SfsShape::kSphere) return (p - centre_in_cam_).norm() - s_;
    if (kind_ == SfsShape::kVase) {
      const double s = (p.y() - centre_in_cam_.y()) / half_height_;
      const double rho2 =
          p.x() * p.x() + (p.z() - centre_in_cam_.z()) * (p.z() - centre_in_cam_.z());
      if (std::abs(s) >= 1) return rho2 + (std::abs(s) - 1) * s_ * s_;
      return rho2 - VaseR2(s);
    }
    return centre_in_cam_.z() - Height(p.x(), p.y()) - p.z();
  }

  // Outward unit normal at a surface point.
  Eigen::Vector3d Normal(const Eigen::Vector3d& p) const {
    if (kind_ == SfsShape::kSphere) return (p - centre_in_cam_).normalized();
    if (kind_ == SfsShape::kVase) {
      const double s = (p.y() - centre_in_cam_.y()) / half_height_, h = 1e-6;
      const double dr2_ds = (VaseR2(s + h) - VaseR2(s - h)) / (2 * h);
      return Eigen::Vector3d(2 * p.x(), -dr2_ds / half_height_, 2 * (p.z() - centre_in_cam_.z()))
          .normalized();
    }
    double hx = 0, hy = 0;
    HeightGradient(p.x(), p.y(), &hx, &hy);
    return Eigen::Vector3d(-hx, -hy, -1).normalized();
  }

  // Depth z of the first surface point along the ray (x, y, 1) z, or a negative value.
  double Trace(const Eigen::Vector3d& ray) const {
    if (kind_ == SfsShape::kBumps) {
      // The ray's x and y are linear in z: skip rays that pass beside the patch.
      const Eigen::Vector3d a = ray * z_near_, b = ray * z_far_;
      if (std::min(a.x(), b.x()) > s_ || std::max(a.x(), b.x()) < -s_ ||
          std::min(a.y(), b.y()) > s_ || std::max(a.y(), b.y()) < -s_) {
        return -1;
      }
    }
    // Steps of ~0.5 mm (sphere, vase) and ~0.6 mm (bumps, whose narrowest feature is a
    // 15 mm wide Gaussian): no surface crossing is skipped, bisection does the rest.
    const int steps = kind_ == SfsShape::kBumps ? 100 : 400;
    const double dz = (z_far_ - z_near_) / steps;
    double z0 = z_near_, f0 = F(ray * z0);
    for (int k = 1; k <= steps; ++k) {
      const double z1 = z_near_ + k * dz, f1 = F(ray * z1);
      if (f0 > 0 && f1 <= 0) {
        double a = z0, b = z1;
        for (int it = 0; it < 60; ++it) {
          const double m = 0.5 * (a + b);
          (F(ray * m) > 0 ? a : b) = m;
        }
        const double z = 0.5 * (a + b);
        if (kind_ == SfsShape::kBumps) {
          const Eigen::Vector3d p = ray * z;
          if (std::abs(p.x()) > s_ || std::abs(p.y()) > s_) return -1;
        }
        return z;
      }
      z0 = z1;
      f0 = f1;
    }
    return -1;
  }

  json ToJson() const {
    json j = {{"shape", ToString(spec_.shape)},
              {"centre_in_camera", {centre_in_cam_.x(), centre_in_cam_.y(), centre_in_cam_.z()}}};
    if (kind_ == SfsShape::kSphere) {
      j["radius"] = s_;
      j["definition"] = "|p - centre| = radius";
    } else if (kind_ == SfsShape::kVase) {
      j["max_radius"] = s_;
      j["half_height"] = half_height_;
      j["definition"] =
          "surface of revolution about the camera y axis through centre: x^2 + (z - cz)^2 = "
          "r(s)^2, s = (y - cy) / half_height in [-1, 1], r(s)^2 = R^2 prof(s)^2 (1 - s^6), "
          "prof(s) = 0.55 + 0.4 exp(-((s - 0.3) / 0.45)^2) + 0.15 exp(-((s + 0.85) / 0.15)^2)";
    } else {
      j["half_width"] = s_;
      json b = json::array();
      for (const auto& g : bumps_) {
        b.push_back(
            {{"x", g[0] * s_}, {"y", g[1] * s_}, {"height", g[2] * s_}, {"sigma", g[3] * s_}});
      }
      j["bumps"] = b;
      j["definition"] =
          "z = cz - sum_k height_k exp(-((x - x_k)^2 + (y - y_k)^2) / (2 sigma_k^2)), |x|, |y| "
          "<= half_width (camera frame, metres)";
    }
    return j;
  }

 private:
  double VaseR2(double s) const {
    const double a = (s - 0.3) / 0.45, b = (s + 0.85) / 0.15;
    const double prof = 0.55 + 0.4 * std::exp(-a * a) + 0.15 * std::exp(-b * b);
    const double s2 = s * s;
    return s_ * s_ * prof * prof * (1 - s2 * s2 * s2);
  }
  double Height(double x, double y) const {
    double h = 0;
    for (const auto& g : bumps_) {
      const double dx = x - g[0] * s_, dy = y - g[1] * s_, sg = g[3] * s_;
      h += g[2] * s_ * std::exp(-(dx * dx + dy * dy) / (2 * sg * sg));
    }
    return h;
  }
  void HeightGradient(double x, double y, double* hx, double* hy) const {
    for (const auto& g : bumps_) {
      const double dx = x - g[0] * s_, dy = y - g[1] * s_, sg = g[3] * s_;
      const double v = g[2] * s_ * std::exp(-(dx * dx + dy * dy) / (2 * sg * sg));
      *hx += -v * dx / (sg * sg);
      *hy += -v * dy / (sg * sg);
    }
  }

  SfsSpec spec_;
  SfsShape kind_;  // switched on per ray step
  Eigen::Vector3d centre_in_cam_;
  double s_;
  double half_height_ = 0;
  double z_near_ = 0, z_far_ = 0;
  std::vector<std::array<double, 4>> bumps_;  // x, y, height, sigma (relative to size)
};

double Shade(const Shape& shape, const Material& material, const LampSpec& lamp,
             const Eigen::Vector3d& p, Eigen::Vector3d* normal) {
  const Eigen::Vector3d n = shape.Normal(p);
  if (normal) *normal = n;
  Eigen::Vector3d l;
  const double e = PointIrradiance(p, n, lamp.position, lamp.intensity, &l);
  if (e <= 0) return 0.0;
  const Eigen::Vector3d v = -p.normalized();
  Angles<double> a = LocalAngles(n, l, v);
  // The first hit faces the camera; only rounding can put it past the horizon.
  a.theta_r = std::min(a.theta_r, kHalfPi);
  return material.Brdf(a) * e;
}

// Unit-z rays through the pixel-square corners and the depth of their first hit (<= 0: miss).
struct CornerHits {
  std::vector<Eigen::Vector3d> rays;
  std::vector<double> z;
};

CornerHits TraceCorners(const CameraModel& camera, const Shape& shape, int threads) {
  const int w1 = camera.width + 1;
  CornerHits c;
  c.rays.resize(static_cast<size_t>(w1) * (camera.height + 1));
  c.z.resize(c.rays.size());
  ParallelFor(camera.height + 1, threads, [&](size_t b, size_t e) {
    for (size_t y = b; y < e; ++y) {
      for (int x = 0; x < w1; ++x) {
        const size_t k = y * w1 + x;
        c.rays[k] = camera.Unproject(Eigen::Vector2d(x - 0.5, y - 0.5));
        c.z[k] = shape.Trace(c.rays[k]);
      }
    }
  });
  return c;
}

// The rendered image and its truth maps.
struct SfsImages {
  cv::Mat image, mask, depth, normals;
  size_t mask_pixels = 0;
  int brightest = 0;  // highest pixel value
};

// Radiance of pixel (x, y): shaded at the centre when the whole footprint is on the object
// (then the truth maps are filled there), averaged over S x S rays on the silhouette.
double PixelRadiance(const Scene& scene, const Shape& shape, const Material& material,
                     const CornerHits& corners, int x, int y, SfsImages* out, size_t* on_object) {
  const int w1 = scene.camera.width + 1, ss = scene.supersampling;
  const size_t i00 = static_cast<size_t>(y) * w1 + x, i10 = i00 + 1, i01 = i00 + w1, i11 = i01 + 1;
  const auto& z = corners.z;
  const int hits = (z[i00] > 0) + (z[i10] > 0) + (z[i01] > 0) + (z[i11] > 0);
  if (hits == 0) return 0.0;
  const Eigen::Vector3d centre_ray = scene.camera.Unproject(Eigen::Vector2d(x, y));
  const double zc = shape.Trace(centre_ray);
  if (hits == 4 && zc > 0) {
    Eigen::Vector3d n;
    const double radiance = Shade(shape, material, scene.lamp, centre_ray * zc, &n);
    out->mask.at<uint8_t>(y, x) = 255;
    out->depth.at<float>(y, x) = static_cast<float>(zc);
    out->normals.at<cv::Vec3f>(y, x) = cv::Vec3f(n.x(), n.y(), n.z());
    ++*on_object;
    return radiance;
  }
  // Silhouette: average over S x S rays in the footprint (background radiance 0).
  const auto& rays = corners.rays;
  double radiance = 0;
  for (int j = 0; j < ss; ++j) {
    for (int i = 0; i < ss; ++i) {
      // Multi-jittered canonical pattern, as in the board renderer.
      const double u = (i * ss + j + 0.5) / (ss * ss), v = (j * ss + i + 0.5) / (ss * ss);
      const Eigen::Vector3d ray = (1 - v) * ((1 - u) * rays[i00] + u * rays[i10]) +
                                  v * ((1 - u) * rays[i01] + u * rays[i11]);
      const double zr = shape.Trace(ray);
      if (zr > 0) radiance += Shade(shape, material, scene.lamp, ray * zr, nullptr);
    }
  }
  return radiance / (ss * ss);
}

SfsImages RenderImages(const Scene& scene, const Shape& shape, const Material& material,
                       const PhotometricChain& chain, const CornerHits& corners, int threads) {
  const int w = scene.camera.width, h = scene.camera.height;
  const double exposure_s = scene.views.exposures_s.front();
  SfsImages out;
  out.image = cv::Mat(h, w, scene.photometric.bit_depth == 8 ? CV_8U : CV_16U);
  out.mask = cv::Mat(h, w, CV_8U, cv::Scalar(0));
  out.depth = cv::Mat(h, w, CV_32F, cv::Scalar(0));
  out.normals = cv::Mat(h, w, CV_32FC3, cv::Scalar(0, 0, 0));
  std::atomic<size_t> mask_count{0};
  std::atomic<int> brightest{0};
  ParallelFor(h, threads, [&](size_t b, size_t e) {
    size_t local = 0;
    int local_max = 0;
    for (size_t y = b; y < e; ++y) {
      std::mt19937_64 rng(RowSeed(scene.seed, 0, y));
      for (int x = 0; x < w; ++x) {
        const double radiance =
            PixelRadiance(scene, shape, material, corners, x, static_cast<int>(y), &out, &local);
        const uint16_t value = chain.Value(radiance, exposure_s, x, static_cast<double>(y), rng);
        local_max = std::max<int>(local_max, value);
        if (out.image.depth() == CV_8U) {
          out.image.at<uint8_t>(y, x) = static_cast<uint8_t>(value);
        } else {
          out.image.at<uint16_t>(y, x) = value;
        }
      }
    }
    mask_count += local;
    int prev = brightest.load();
    while (local_max > prev && !brightest.compare_exchange_weak(prev, local_max)) {
    }
  });
  out.mask_pixels = mask_count;
  out.brightest = brightest;
  return out;
}

// lamp.json: the lamp in the camera frame, and for a linear camera without vignetting the
// radiance of one digital number.
json SfsLampJson(const Scene& scene, const PhotometricChain& chain) {
  const auto& p = scene.lamp.position;
  json lamp = {{"frame", ToString(scene.lamp.frame)},  // kCamera (Scene::Check)
               {"position", {p.x(), p.y(), p.z()}},
               {"collocated", p.norm() < 1e-9},
               {"intensity", scene.lamp.intensity},
               {"falloff", "inverse-square: E = intensity * cos(theta_i) / d^2"}};
  const auto& ph = scene.photometric;
  const bool linear =
      ph.response == ResponseCurve::kLinear && ph.vignetting == std::array<double, 3>{0, 0, 0};
  if (linear) {
    // Radiance of one digital number above the black level (linear response, no vignetting).
    lamp["radiance_per_dn"] = 1.0 / ((chain.max_value() - ph.black_level) * ph.exposure_scale *
                                     scene.views.exposures_s.front());
    lamp["black_level"] = ph.black_level;
  }
  return lamp;
}

json SfsTruthJson(const Scene& scene, const Shape& shape, const json& material_json,
                  const json& lamp, const PhotometricChain& chain) {
  const CameraModel& camera = scene.camera;
  return {
      {"format", "gonio-synth-truth"},
      {"version", 1},
      {"scene_type", ToString(scene.type)},
      {"object", shape.ToJson()},
      {"material", material_json},
      {"lamp", lamp},
      {"camera",
       {{"file", "camera.cameramodel"},
        {"lens_model", LensModelName(camera.lens_model)},
        {"intrinsics", camera.intrinsics},
        {"width", camera.width},
        {"height", camera.height}}},
      {"image", {{"file", "image.png"}, {"exposure_s", scene.views.exposures_s.front()}}},
      {"mask",
       {{"file", "mask.png"}, {"meaning", "255 where the whole pixel footprint is on the object"}}},
      {"depth",
       {{"file", "depth.tiff"},
        {"type", "float32"},
        {"unit", "m"},
        {"meaning", "camera-frame z of the surface at the pixel centre; 0 outside the mask"}}},
      {"normals",
       {{"file", "normals.tiff"},
        {"type", "float32 x3"},
        {"channels", {"x", "y", "z"}},
        {"frame", "camera"},
        {"meaning",
         "outward unit normal at the pixel centre, 0 outside the mask; read "
         "with cv::imread(IMREAD_UNCHANGED), channel 0 = x"}}},
      {"photometric", chain.ToJson()},
      {"scene", SceneToJson(scene)}};
}

// The input folder of `gonio sfs`: image, mask, depth and normal truth, camera, material,
// lamp, truth.json.
void WriteSfsFiles(const Scene& scene, const Shape& shape, const Material& material,
                   const PhotometricChain& chain, const SfsImages& images,
                   const fs::path& out_dir) {
  auto write_image = [&](const std::string& name, const cv::Mat& m) {
    WriteImage(out_dir / name, m);
  };
  write_image("image.png", images.image);
  write_image("mask.png", images.mask);
  WriteFloatTiff(out_dir / "depth.tiff", images.depth);
  WriteFloatTiff(out_dir / "normals.tiff", images.normals);
  scene.camera.Write(out_dir / "camera.cameramodel", "gonio synth: the camera of this sfs scene");
  const json material_json = material.ToJson();
  WriteJsonAtomically(out_dir / "material.json", {{"selected", material.model()},
                                                  {"candidates", json::array({material_json})}});
  const json lamp = SfsLampJson(scene, chain);
  WriteJsonAtomically(out_dir / "lamp.json", lamp);
  WriteJsonAtomically(out_dir / "truth.json",
                      SfsTruthJson(scene, shape, material_json, lamp, chain));
}

}  // namespace

std::string SfsRenderResult::Report() const {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%zu mask pixels in %.2f s, brightest pixel at %.2f of range",
                mask_pixels, seconds, max_value_fraction);
  return buf;
}

SfsRenderResult RenderSfsScene(const Scene& scene, const fs::path& out_dir, int threads) {
  const auto start = std::chrono::steady_clock::now();
  scene.Check();
  const Material material(scene.material);
  const Shape shape(scene.sfs);
  const PhotometricChain chain(scene.photometric, scene.camera);
  EnsureDirectory(out_dir);
  const CornerHits corners = TraceCorners(scene.camera, shape, threads);
  const SfsImages images = RenderImages(scene, shape, material, chain, corners, threads);
  if (images.mask_pixels == 0) {
    throw InputError("sfs scene: the object is not visible in the image");
  }
  WriteSfsFiles(scene, shape, material, chain, images, out_dir);
  SfsRenderResult result;
  result.mask_pixels = images.mask_pixels;
  result.max_value_fraction = images.brightest / chain.max_value();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace gonio::synth
