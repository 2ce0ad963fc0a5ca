// `gonio export --maps DIR`: a `gonio maps` output wired to each renderer's rough-diffuse BSDF
// through image textures (docs/maps.md "Export"). The renderer's albedo and roughness differ
// from the maps' (Oren-Nayar's rho and sigma) except for Mitsuba's roughdiffuse, so each texel
// is converted through a table of renderer fits (export/renderer_fit.h) over albedo and sigma,
// interpolated bilinearly; the table's worst fit error is written in the file's header.
#include <cmath>
#include <fstream>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "common/error.h"
#include "common/float_tiff.h"
#include "common/io.h"
#include "common/math.h"
#include "common/parallel.h"
#include "common/provenance.h"
#include "export/export.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

// The renderer's (albedo, shape) for the maps' (rho, sigma) on a grid, with the worst fit.
class ConversionTable {
 public:
  ConversionTable(RendererFunction f, const std::string& model, bool has_sigma,
                  const FitDomain& domain)
      : sigma_max_(has_sigma ? 0.9 : 0.0) {
    // The table's fits are independent: on all threads (133 least-squares fits, the most of
    // the export's time).
    std::vector<RendererFit> fits(kRho * kSigma);
    ParallelFor(fits.size(), 0, [&](size_t b, size_t e) {
      for (size_t k = b; k < e; ++k) {
        const double rho = RhoAt(static_cast<int>(k) / kSigma);
        const double sigma = SigmaAt(static_cast<int>(k) % kSigma);
        const std::vector<double> params =
            has_sigma ? std::vector<double>{rho, sigma} : std::vector<double>{rho};
        fits[k] = FitRenderer(f, MakeMaterial(model, params), domain);
      }
    });
    for (int i = 0; i < kRho; ++i) {
      for (int j = 0; j < kSigma; ++j) {
        const RendererFit& fit = fits[i * kSigma + j];
        albedo_[i][j] = fit.albedo[0];
        shape_[i][j] = fit.shape;
        worst_ = std::max(worst_, fit.rel_rms);
        exact_ = fit.exact;
      }
    }
  }
  // Bilinear in (rho, sigma), clamped to the table.
  void Convert(double rho, double sigma, double* albedo, double* shape) const {
    const double u = std::clamp((rho - kRhoLo) / (kRhoHi - kRhoLo) * (kRho - 1), 0.0, kRho - 1.0);
    const double v =
        sigma_max_ > 0 ? std::clamp(sigma / sigma_max_ * (kSigma - 1), 0.0, kSigma - 1.0) : 0.0;
    const int i = std::min(static_cast<int>(u), kRho - 2),
              j = std::min(static_cast<int>(v), kSigma - 2);
    const double fu = u - i, fv = v - j;
    auto lerp = [&](const double(&t)[kRho][kSigma]) {
      return (1 - fu) * ((1 - fv) * t[i][j] + fv * t[i][j + 1]) +
             fu * ((1 - fv) * t[i + 1][j] + fv * t[i + 1][j + 1]);
    };
    *albedo = rho < kRhoLo ? rho / kRhoLo * lerp(albedo_)
                           : lerp(albedo_) * (rho > kRhoHi ? rho / kRhoHi : 1.0);
    *shape = lerp(shape_);
  }
  double worst() const { return worst_; }
  bool exact() const { return exact_; }

 private:
  static constexpr int kRho = 7, kSigma = 19;
  static constexpr double kRhoLo = 0.05, kRhoHi = 0.95;
  double RhoAt(int i) const { return kRhoLo + (kRhoHi - kRhoLo) * i / (kRho - 1); }
  double SigmaAt(int j) const { return sigma_max_ * j / (kSigma - 1); }
  double sigma_max_;
  double albedo_[kRho][kSigma] = {}, shape_[kRho][kSigma] = {};
  double worst_ = 0;
  bool exact_ = false;
};

// Portable float map (Mitsuba 0.6 reads PFM, not TIFF): "PF" (RGB) or "Pf" (grey), rows
// bottom to top, little-endian.
void WritePfm(const fs::path& path, const cv::Mat& m) {
  WriteAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << (m.channels() == 3 ? "PF" : "Pf") << "\n" << m.cols << " " << m.rows << "\n-1.0\n";
    for (int y = m.rows - 1; y >= 0; --y) {
      out.write(reinterpret_cast<const char*>(m.ptr<float>(y)),
                static_cast<std::streamsize>(m.cols * m.channels() * sizeof(float)));
    }
    return static_cast<bool>(out);
  });
}

struct MapsFiles {
  cv::Mat albedo, roughness, normal, height;  // RGB order (common/float_tiff.h)
  std::string model;
  bool has_sigma = false, absolute = false;
  double texel = 0;
};

MapsFiles ReadMapsFiles(const fs::path& dir) {
  const nlohmann::json j = ReadJsonFile(dir / "maps.json");
  MapsFiles m;
  m.model = j.at("model").get<std::string>();
  if (m.model != "oren-nayar" && m.model != "oren-nayar-qualitative" && m.model != "lambert") {
    throw InputError(dir.string() + "/maps.json: model " + m.model +
                     " has no renderer conversion (oren-nayar, oren-nayar-qualitative, lambert)");
  }
  m.albedo = ReadFloatTiff(dir / "albedo.tiff");
  if (m.albedo.channels() == 1) cv::merge(std::vector<cv::Mat>(3, m.albedo), m.albedo);
  m.has_sigma = m.model != "lambert";
  m.roughness =
      m.has_sigma ? ReadFloatTiff(dir / "roughness.tiff") : cv::Mat::zeros(m.albedo.size(), CV_32F);
  m.normal = ReadFloatTiff(dir / "normal.tiff");
  m.height = ReadFloatTiff(dir / "height.tiff");
  m.absolute = j.at("lamp").at("absolute").get<bool>();
  m.texel = j.at("grid").at("texel_m").get<double>();
  return m;
}

std::string Stem(const fs::path& out) { return out.stem().string(); }

}  // namespace

TextureExportResult ExportMaps(const fs::path& maps_dir, const ExportOptions& options,
                               const fs::path& out, bool allow_relative) {
  options.Check();
  const auto function = RendererFunctionOf(options.format);
  if (!function || options.format == ExportFormat::kPbrt3) {
    throw InputError("--maps: textures are exported for mitsuba, blender and materialx");
  }
  const MapsFiles m = ReadMapsFiles(maps_dir);
  if (!m.absolute && !allow_relative) {
    throw InputError(maps_dir.string() +
                     ": the albedo maps are relative (no white reference); --allow-relative "
                     "exports them as they are");
  }
  const ConversionTable table(*function, m.model, m.has_sigma, options.domain);
  cv::Mat base(m.albedo.size(), CV_32FC3), shape(m.albedo.size(), CV_32F);
  for (int y = 0; y < base.rows; ++y) {
    for (int x = 0; x < base.cols; ++x) {
      const cv::Vec3f a = m.albedo.at<cv::Vec3f>(y, x);
      const double sigma = m.roughness.at<float>(y, x);
      double s = 0;
      for (int c = 0; c < 3; ++c) {
        double albedo = 0;
        table.Convert(a[c], sigma, &albedo, &s);
        base.at<cv::Vec3f>(y, x)[c] = static_cast<float>(albedo);
      }
      double mean_albedo = 0;
      table.Convert((a[0] + a[1] + a[2]) / 3.0, sigma, &mean_albedo, &s);
      // Mitsuba's roughdiffuse takes alpha = sqrt(2) sigma (docs/export.md).
      shape.at<float>(y, x) =
          static_cast<float>(options.format == ExportFormat::kMitsuba ? std::sqrt(2.0) * s : s);
    }
  }
  const fs::path dir = fs::absolute(out).parent_path();
  EnsureDirectory(dir);
  const std::string stem = Stem(out);
  TextureExportResult r;
  r.format = options.format;
  r.width = base.cols;
  r.height = base.rows;
  r.worst_rel_rms = table.worst();
  r.exact = table.exact();
  const std::vector<std::string> header = {
      fmt::format("gonio {} export of the maps in {}", Version(), maps_dir.string()),
      fmt::format("maps: {} x {} texels of {:.4f} mm, model {}{}", base.cols, base.rows,
                  1e3 * m.texel, m.model, m.absolute ? "" : " (relative albedo)"),
      "target: " + FormatName(options.format) + " rough-diffuse BSDF with image textures",
      table.exact() ? "the maps convert exactly (same function)"
                    : fmt::format("per-texel conversion through least-squares renderer fits "
                                  "(worst relative RMS over the table {:.2f}%)",
                                  100 * table.worst()),
      "normal map: tangent space, X right, Y up the map, Z outward (OpenGL convention)"};
  std::string text;
  if (options.format == ExportFormat::kMitsuba) {
    r.files = {stem + "_reflectance.pfm", stem + "_alpha.pfm", stem + "_height.pfm"};
    WritePfm(dir / r.files[0], base);
    WritePfm(dir / r.files[1], shape);
    WritePfm(dir / r.files[2], m.height);
    text = MitsubaTexturedText(header, r.files, base.cols * m.texel);
  } else {
    r.files = {stem + "_basecolor.tiff", stem + "_roughness.tiff", stem + "_normal.tiff"};
    WriteFloatTiff(dir / r.files[0], base);
    WriteFloatTiff(dir / r.files[1], shape);
    // Normal maps are read as colours (n + 1) / 2 by both renderers.
    cv::Mat encoded;
    m.normal.convertTo(encoded, CV_32FC3, 0.5, 0.5);
    WriteFloatTiff(dir / r.files[2], encoded);
    text = options.format == ExportFormat::kBlender ? BlenderTexturedText(header, r.files)
                                                    : MaterialxTexturedText(header, r.files);
  }
  WriteTextAtomically(out, text);
  return r;
}

std::string TextureExportResult::Report() const {
  return fmt::format(
      "{}: {} x {} textures ({}), {}\n", FormatName(format), width, height, fmt::join(files, ", "),
      exact ? "exact conversion"
            : fmt::format("worst table fit {:.2f}% relative RMS", 100 * worst_rel_rms));
}

}  // namespace gonio
