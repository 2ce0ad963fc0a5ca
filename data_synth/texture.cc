#include "data_synth/texture.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "common/error.h"
#include "common/math.h"

namespace gonio::synth {
namespace {

constexpr int kWaves = 6;

// kWaves cosines with uniform directions, wavelengths uniform in [wavelength, 2 wavelength] and
// uniform phases, scaled to unit RMS over the plane.
WaveField MakeWaves(std::mt19937_64& rng, double wavelength) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  WaveField w;
  for (int k = 0; k < kWaves; ++k) {
    const double dir = 2 * kPi * u(rng);
    const double lambda = wavelength * (1.0 + u(rng));
    w.k.emplace_back(2 * kPi / lambda * std::cos(dir), 2 * kPi / lambda * std::sin(dir));
    w.phase.push_back(2 * kPi * u(rng));
  }
  w.scale = 1.0 / std::sqrt(0.5 * kWaves);
  return w;
}

void Require(bool ok, const std::string& message) {
  if (!ok) throw InputError("texture." + message);
}

}  // namespace

double WaveField::Value(double x, double y) const {
  double s = 0;
  for (size_t i = 0; i < k.size(); ++i) s += std::cos(k[i].x() * x + k[i].y() * y + phase[i]);
  return scale * s;
}

Eigen::Vector2d WaveField::Gradient(double x, double y) const {
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < k.size(); ++i)
    g -= std::sin(k[i].x() * x + k[i].y() * y + phase[i]) * k[i];
  return scale * g;
}

Eigen::Vector3d TexturePoint::Normal() const {
  return Eigen::Vector3d(-slope.x(), -slope.y(), -1.0).normalized();
}

void CheckTextureSpec(const TextureSpec& s, double roughness_lo, double roughness_hi) {
  if (!s.enabled()) return;
  Require(!s.materials.empty() && s.materials.size() <= 8, "materials: give 1 to 8 materials");
  for (const auto& m : s.materials) {
    for (double a : m.albedo) Require(a > 0 && a <= 1, "materials: an albedo outside (0, 1]");
    Require(m.roughness >= roughness_lo && m.roughness <= roughness_hi,
            "materials: a roughness outside the model's range");
  }
  Require(s.cell_size > 0, "cell_size: must be > 0");
  Require(s.albedo_variation >= 0 && s.albedo_variation < 0.5,
          "albedo_variation: must be in [0, 0.5)");
  Require(s.albedo_wavelength > 0, "albedo_wavelength: must be > 0");
  Require(s.slope_deg >= 0 && s.slope_deg <= 30, "slope_deg: must be in [0, 30]");
  Require(s.height_wavelength > 0, "height_wavelength: must be > 0");
  Require(s.roughness_variation >= 0, "roughness_variation: must be >= 0");
  Require(s.roughness_wavelength > 0, "roughness_wavelength: must be > 0");
  Require(s.truth_texel >= 1e-5 && s.truth_texel <= 0.01, "truth_texel: must be in [1e-5, 0.01] m");
}

Texture::Texture(const TextureSpec& spec, const std::array<double, 4>& region, double roughness_lo,
                 double roughness_hi)
    : spec_(spec), roughness_lo_(roughness_lo), roughness_hi_(roughness_hi) {
  CheckTextureSpec(spec, roughness_lo, roughness_hi);
  std::mt19937_64 rng(spec.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // Voronoi sites jittered on a grid one cell apart, over the region and one cell beyond it.
  const int nx = static_cast<int>(std::ceil((region[2] - region[0]) / spec.cell_size)) + 2;
  const int ny = static_cast<int>(std::ceil((region[3] - region[1]) / spec.cell_size)) + 2;
  const int n_materials = static_cast<int>(spec.materials.size());
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      cell_sites_.emplace_back(region[0] + (i - 1 + u(rng)) * spec.cell_size,
                               region[1] + (j - 1 + u(rng)) * spec.cell_size);
      cell_material_.push_back(static_cast<int>(cell_material_.size()) % n_materials);
    }
  }
  // Shuffled, so neighbouring cells differ at random but every material keeps its share.
  std::shuffle(cell_material_.begin(), cell_material_.end(), rng);
  luminance_ = MakeWaves(rng, spec.albedo_wavelength);
  for (auto& c : chroma_) c = MakeWaves(rng, spec.albedo_wavelength);
  roughness_ = MakeWaves(rng, spec.roughness_wavelength);
  height_ = MakeWaves(rng, spec.height_wavelength);
  // RMS gradient of the unit-RMS field: scale * sqrt(sum |k|^2 / 2).
  double k2 = 0;
  for (const auto& k : height_.k) k2 += 0.5 * k.squaredNorm();
  height_amplitude_ = std::tan(DegToRad(spec.slope_deg)) / (height_.scale * std::sqrt(k2));
}

int Texture::Material(double x, double y) const {
  if (spec_.materials.size() == 1) return 0;
  size_t best = 0;
  double best_d2 = INFINITY;
  for (size_t i = 0; i < cell_sites_.size(); ++i) {
    const double d2 = (cell_sites_[i] - Eigen::Vector2d(x, y)).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = i;
    }
  }
  return cell_material_[best];
}

TexturePoint Texture::At(double x, double y) const {
  TexturePoint p;
  p.material = Material(x, y);
  const TextureMaterial& m = spec_.materials[p.material];
  const double v = spec_.albedo_variation;
  const double lum = luminance_.Value(x, y);
  for (int c = 0; c < 3; ++c) {
    p.albedo[c] =
        std::clamp(m.albedo[c] * (1 + v * lum + 0.3 * v * chroma_[c].Value(x, y)), 0.02, 0.98);
  }
  p.roughness = std::clamp(m.roughness + spec_.roughness_variation * roughness_.Value(x, y),
                           roughness_lo_, roughness_hi_);
  p.height = height_amplitude_ * height_.Value(x, y);
  p.slope = height_amplitude_ * height_.Gradient(x, y);
  return p;
}

}  // namespace gonio::synth
