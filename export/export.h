// `gonio export`: a fitted material in the formats renderers and BRDF tools read: Mitsuba 0.6
// XML, a pbrt-v3 Material line, a Blender (Cycles) Python script, a MaterialX document, an
// ASTM E1392-style table, a MERL .binary file. Conversions and errors: docs/export.md.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "estimation/fit/fit_file.h"
#include "export/renderer_fit.h"

namespace gonio {

enum class ExportFormat { kMitsuba, kPbrt3, kBlender, kMaterialx, kAstm, kMerl };
// InputError naming --format for anything else.
ExportFormat ParseExportFormat(const std::string& s);
std::string FormatName(ExportFormat f);

// The ASTM table's grid, degrees, in the standard's azimuth convention (ASTM E1392 / E2387,
// after Stover, "Optical Scattering", ch. 1: the incident beam's plane is phi_i = 0, and the
// specular beam lies at theta_s = theta_i, phi_s = 0; phi_s = 180 is the retro direction). gonio's
// phi (docs/conventions.md, 0 = backscatter) is 180 - phi_s: AstmAzimuthToGonio.
struct AstmGrid {
  std::vector<double> theta_i_deg = {0, 10, 20, 30, 40, 50, 60, 70, 80};
  std::vector<double> theta_s_deg = {0,  5,  10, 15, 20, 25, 30, 35, 40,
                                     45, 50, 55, 60, 65, 70, 75, 80, 85};
  std::vector<double> phi_s_deg = {0, 15, 30, 45, 60, 75, 90, 105, 120, 135, 150, 165, 180};
  void Check() const;  // InputError: angles outside [0, 89.9] / [0, 360], empty lists
};

struct ExportOptions {
  ExportFormat format = ExportFormat::kMitsuba;
  FitDomain domain;  // where renderer parameters must reproduce the fit
  AstmGrid grid;
  void Check() const;
};

struct ExportResult {
  ExportFormat format = ExportFormat::kMitsuba;
  std::optional<RendererFit> renderer;  // renderer formats only
  size_t n_values = 0;                  // table formats: values written
  std::string Report() const;
};

// Writes `out` atomically. InputError for bad options; NumericalError when a value cannot be
// computed (nothing is written then).
ExportResult ExportMaterial(const FittedMaterial& material, const ExportOptions& options,
                            const std::filesystem::path& out);

// The renderer function each renderer format targets (std::nullopt for table formats).
std::optional<RendererFunction> RendererFunctionOf(ExportFormat f);

// Table formats (export/tables.cc).
size_t WriteMerlBinary(const FittedMaterial& material, const std::filesystem::path& out);
std::string AstmTable(const FittedMaterial& material, const AstmGrid& grid, size_t* n_values);

// `gonio export --maps DIR`: the maps of `gonio maps` as image textures wired to the renderer's
// rough-diffuse BSDF (mitsuba: roughdiffuse under a bumpmap, PFM textures; blender: Diffuse
// BSDF with Image Texture and Normal Map nodes; materialx: oren_nayar_diffuse_bsdf with image
// and normalmap nodes; float TIFF textures), written beside `out` as OUTSTEM_*.
struct TextureExportResult {
  ExportFormat format = ExportFormat::kMitsuba;
  int width = 0, height = 0;
  std::vector<std::string> files;  // the textures, beside the output file
  bool exact = false;              // the renderer evaluates the maps' own function
  double worst_rel_rms = 0;        // of the per-texel conversion table's renderer fits
  std::string Report() const;
};
// InputError for pbrt3 or a table format, a maps model without a renderer conversion, or
// relative maps (no white reference) without allow_relative.
TextureExportResult ExportMaps(const std::filesystem::path& maps_dir, const ExportOptions& options,
                               const std::filesystem::path& out, bool allow_relative);

// The texts of the textured exports (textures: reflectance / basecolor, alpha / roughness,
// height (mitsuba) / normal, in that order; side_m: the maps' side, for mitsuba's bump scale).
std::string MitsubaTexturedText(const std::vector<std::string>& header,
                                const std::vector<std::string>& textures, double side_m);
std::string BlenderTexturedText(const std::vector<std::string>& header,
                                const std::vector<std::string>& textures);
std::string MaterialxTexturedText(const std::vector<std::string>& header,
                                  const std::vector<std::string>& textures);

// The comment lines every export starts with: tool, source fit, material, conversion.
std::vector<std::string> ExportHeader(const FittedMaterial& material,
                                      const std::optional<RendererFit>& renderer);

}  // namespace gonio
