// Textured samples (docs/maps.md): the sample's albedo (RGB), surface relief (a height field,
// shaded through its normal as a bump map: the geometry stays planar), roughness and
// material vary over the sample. Procedural and deterministic from `seed`, so the truth can
// be written at any resolution:
//
//   material   Voronoi cells of about `cell_size` on the sample, each given one of the
//              materials (every material appears when the sample holds enough cells)
//   albedo_c   base_c (1 + v W0(x, y) + 0.3 v W_c(x, y)), clamped to [0.02, 0.98]
//   roughness  the material's, plus roughness_variation Wr(x, y), clamped to the registry range
//   height     h = sum_k a cos(k_k . x + phase_k), rms slope tan(slope_deg)
//
// W are sums of 6 cosines with random directions and wavelengths in [wavelength, 2 wavelength],
// scaled to unit RMS. Heights are measured along the outward normal (-z of the board frame), so
// the outward normal is normalize(-dh/dx, -dh/dy, -1) in the board frame.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace gonio::synth {

struct TextureMaterial {
  std::array<double, 3> albedo = {0.6, 0.6, 0.6};  // R, G, B: the model's albedo parameter
  double roughness = 0.5;  // the model's second parameter (oren-nayar: sigma, rad)
};

// scene.json's texture.type words "none" and "procedural" (read and written in scene.cc).
enum class TextureType { kNone, kProcedural };

struct TextureSpec {
  TextureType type = TextureType::kNone;
  uint64_t seed = 7;  // the pattern's own seed (the scene's seed drives the noise)
  std::vector<TextureMaterial> materials = {TextureMaterial{}};
  double cell_size = 0.03;             // metres, material cells
  double albedo_variation = 0.1;       // RMS relative albedo modulation within a material
  double albedo_wavelength = 0.01;     // metres, shortest wavelength of the modulation
  double slope_deg = 6.0;              // RMS slope of the relief, degrees (0: flat)
  double height_wavelength = 0.012;    // metres, shortest wavelength of the relief
  double roughness_variation = 0.0;    // RMS of the roughness modulation (the parameter's unit)
  double roughness_wavelength = 0.02;  // metres
  double truth_texel = 0.00025;        // metres, texel of the truth maps beside truth.json
  bool enabled() const { return type != TextureType::kNone; }
};

// One point of the textured surface.
struct TexturePoint {
  std::array<double, 3> albedo;  // R, G, B
  double roughness = 0;
  int material = 0;
  double height = 0;               // metres, outward
  Eigen::Vector2d slope;           // dh/dx, dh/dy in the board frame
  Eigen::Vector3d Normal() const;  // outward unit normal, board frame
};

// A sum of cosines with unit RMS and its gradient.
struct WaveField {
  std::vector<Eigen::Vector2d> k;  // rad/m
  std::vector<double> phase;
  double scale = 1;
  double Value(double x, double y) const;
  Eigen::Vector2d Gradient(double x, double y) const;
};

class Texture {
 public:
  // region: the sample rectangle [xmin, ymin, xmax, ymax] (board frame, metres); roughness_lo
  // / hi: the registry bounds of the model's roughness parameter.
  Texture(const TextureSpec& spec, const std::array<double, 4>& region, double roughness_lo,
          double roughness_hi);
  TexturePoint At(double x, double y) const;
  int Material(double x, double y) const;
  const TextureSpec& spec() const { return spec_; }

 private:
  TextureSpec spec_;
  double roughness_lo_, roughness_hi_;
  std::vector<Eigen::Vector2d> cell_sites_;
  std::vector<int> cell_material_;
  WaveField luminance_, chroma_[3], roughness_, height_;
  double height_amplitude_ = 0;
};

// InputError naming the key when the spec is invalid (no materials, a material outside
// [0, 1] or outside the model's roughness range, sizes <= 0).
void CheckTextureSpec(const TextureSpec& spec, double roughness_lo, double roughness_hi);

}  // namespace gonio::synth
