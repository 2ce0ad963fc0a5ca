// The files of `gonio maps` (docs/formats.md "maps output"): 32-bit float TIFF maps, 8-bit PNG
// previews, per-view re-renders and residuals, maps.json and report/index.html, written into
// a temporary folder that replaces `out` as a whole.
#include <unistd.h>
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "common/error.h"
#include "common/float_tiff.h"
#include "common/io.h"
#include "common/math.h"
#include "estimation/maps/maps.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

bool IsInside(const fs::path& inner, const fs::path& outer) {
  const fs::path a = fs::weakly_canonical(fs::absolute(inner));
  const fs::path b = fs::weakly_canonical(fs::absolute(outer));
  auto ia = a.begin();
  for (auto ib = b.begin(); ib != b.end(); ++ib, ++ia) {
    if (ib->empty()) continue;
    if (ia == a.end() || *ia != *ib) return false;
  }
  return true;
}

// A map image from per-texel values (channels per texel), 0 where the texel is not fitted.
cv::Mat MapImage(const TexelData& d, const std::vector<uint8_t>& fitted, int channels,
                 const std::function<float(size_t t, int c)>& value) {
  cv::Mat m(d.grid.height, d.grid.width, CV_32FC(channels), cv::Scalar::all(0));
  for (size_t t = 0; t < d.grid.size(); ++t) {
    if (!fitted[t]) continue;
    float* px = m.ptr<float>(static_cast<int>(t / d.grid.width)) + (t % d.grid.width) * channels;
    for (int c = 0; c < channels; ++c) {
      const float v = value(t, c);
      px[c] = std::isfinite(v) ? v : 0.f;
    }
  }
  return m;
}

// The 99th percentile of the positive values of a float image (a preview's white point).
double WhitePoint(const cv::Mat& m) {
  std::vector<float> v;
  for (int y = 0; y < m.rows; ++y) {
    const float* p = m.ptr<float>(y);
    for (int x = 0; x < m.cols * m.channels(); ++x) {
      if (p[x] > 0) v.push_back(p[x]);
    }
  }
  if (v.empty()) return 1.0;
  std::nth_element(v.begin(), v.begin() + v.size() * 99 / 100, v.end());
  return std::max(1e-30f, v[v.size() * 99 / 100]);
}

// 8-bit preview: (value - lo) / (hi - lo), sRGB-encoded when `srgb`; RGB stored as OpenCV's BGR.
void WritePreview(const fs::path& path, const cv::Mat& m, double lo, double hi, bool srgb) {
  cv::Mat out(m.rows, m.cols, CV_8UC(m.channels()));
  for (int y = 0; y < m.rows; ++y) {
    const float* p = m.ptr<float>(y);
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int x = 0; x < m.cols; ++x) {
      for (int c = 0; c < m.channels(); ++c) {
        double u = std::clamp((p[x * m.channels() + c] - lo) / (hi - lo), 0.0, 1.0);
        if (srgb) u = u <= 0.0031308 ? 12.92 * u : 1.055 * std::pow(u, 1 / 2.4) - 0.055;
        const int k = m.channels() == 3 ? 2 - c : c;
        o[x * m.channels() + k] = static_cast<uint8_t>(std::lround(255 * u));
      }
    }
  }
  WriteAtomically(path, [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), out); });
}

void WriteMap(const fs::path& dir, const std::string& stem, const cv::Mat& m, double lo, double hi,
              bool srgb = false) {
  WriteFloatTiff(dir / (stem + ".tiff"), m);
  WritePreview(dir / (stem + ".png"), m, lo, hi, srgb);
}

void WriteMaterials(const fs::path& dir, const MapsResult& r) {
  const TexelData& d = r.data;
  cv::Mat labels(d.grid.height, d.grid.width, CV_32F, cv::Scalar(-1));
  cv::Mat colour(d.grid.height, d.grid.width, CV_8UC3, cv::Scalar::all(0));
  static const cv::Vec3b kPalette[] = {{180, 119, 31},  {14, 127, 255},  {44, 160, 44},
                                       {40, 39, 214},   {189, 103, 148}, {75, 86, 140},
                                       {194, 119, 227}, {127, 127, 127}, {34, 189, 188},
                                       {207, 190, 23},  {232, 199, 174}, {120, 187, 255}};
  for (size_t t = 0; t < d.grid.size(); ++t) {
    const int k = r.fit.cluster[t];
    if (k < 0) continue;
    const int y = static_cast<int>(t / d.grid.width), x = static_cast<int>(t % d.grid.width);
    labels.at<float>(y, x) = static_cast<float>(k);
    colour.at<cv::Vec3b>(y, x) = kPalette[k % 12];
  }
  WriteFloatTiff(dir / "materials.tiff", labels);
  WriteAtomically(dir / "materials.png",
                  [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), colour); });
  cv::Mat mask(d.grid.height, d.grid.width, CV_8U, cv::Scalar(0));
  for (size_t t = 0; t < d.grid.size(); ++t) {
    if (r.fit.fitted[t])
      mask.at<uint8_t>(static_cast<int>(t / d.grid.width), t % d.grid.width) = 255;
  }
  WriteAtomically(dir / "mask.png",
                  [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), mask); });
  cv::Mat edges(d.grid.height, d.grid.width, CV_8U, cv::Scalar(0));
  for (size_t t = 0; t < r.fit.edges.edge.size(); ++t) {
    if (r.fit.fitted[t] && r.fit.edges.edge[t])
      edges.at<uint8_t>(static_cast<int>(t / d.grid.width), t % d.grid.width) = 255;
  }
  WriteAtomically(dir / "edges.png",
                  [&](const fs::path& tmp) { return cv::imwrite(tmp.string(), edges); });
}

// Albedo-like maps, normal, height, roughness and their standard deviations.
void WriteFittedMaps(const fs::path& dir, const MapsResult& r) {
  const TexelFit& f = r.fit;
  const TexelData& d = r.data;
  const MapsModelInfo info = InfoOf(f.model);
  const int C = f.channels, m = f.m;
  for (int k = 0; k < m; ++k) {
    const std::string name = info.channel_param_names[k];
    const cv::Mat w =
        MapImage(d, f.fitted, C, [&](size_t t, int c) { return f.w[(t * C + c) * m + k]; });
    WriteMap(dir, name, w, 0.0, f.lamp.absolute() && k == 0 ? 1.0 : WhitePoint(w), true);
    const cv::Mat sd =
        MapImage(d, f.fitted, C, [&](size_t t, int c) { return f.sd_w[(t * C + c) * m + k]; });
    WriteMap(dir, "sd_" + name, sd, 0.0, WhitePoint(sd));
  }
  const cv::Mat normal = MapImage(d, f.fitted, 3, [&](size_t t, int c) {
    // Tangent space (docs/maps.md): X = board +x, Y = board -y, Z = outward.
    const Eigen::Vector3d n = Eigen::Vector3d(-f.p[t], f.q[t], 1.0).normalized();
    return static_cast<float>(n(c));
  });
  WriteMap(dir, "normal", normal, -1.0, 1.0);
  const cv::Mat sd_normal =
      MapImage(d, f.fitted, 1, [&](size_t t, int) { return f.sd_normal_deg[t]; });
  WriteMap(dir, "sd_normal", sd_normal, 0.0, WhitePoint(sd_normal));
  const cv::Mat height = MapImage(d, f.fitted, 1, [&](size_t t, int) { return r.height[t]; });
  double lo = 0, hi = 0;
  cv::minMaxLoc(height, &lo, &hi);
  WriteMap(dir, "height", height, lo, hi > lo ? hi : lo + 1e-9);
  if (info.has_roughness) {
    const cv::Mat rough = MapImage(d, f.fitted, 1, [&](size_t t, int) { return f.r[t]; });
    WriteMap(dir, "roughness", rough, info.roughness_lo, info.roughness_hi);
    const cv::Mat sd_r = MapImage(d, f.fitted, 1, [&](size_t t, int) { return f.sd_r[t]; });
    WriteMap(dir, "sd_roughness", sd_r, 0.0, WhitePoint(sd_r));
  }
}

std::string SafeStem(const std::string& name) {
  std::string s = fs::path(name).stem().string();
  for (char& c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
  }
  return s;
}

// Every view re-rendered from the maps and its residual (predicted - measured) / sigma.
void WriteViews(const fs::path& dir, const MapsResult& r) {
  const TexelData& d = r.data;
  const int C = d.channels;
  EnsureDirectory(dir);
  for (size_t v = 0; v < d.views.size(); ++v) {
    const ViewSamples& vs = d.samples[v];
    if (vs.valid.empty()) continue;
    const std::vector<float> pred = PredictView(d, r.fit, v);
    const std::string stem = fmt::format("{:02d}_{}", v, SafeStem(d.views[v].name));
    const cv::Mat rendered =
        MapImage(d, r.fit.fitted, C, [&](size_t t, int c) { return pred[t * C + c]; });
    WriteMap(dir, stem + "_rendered", rendered, 0.0, WhitePoint(rendered), true);
    std::vector<uint8_t> both(d.grid.size());
    for (size_t t = 0; t < both.size(); ++t) both[t] = vs.valid[t] && r.fit.fitted[t];
    const cv::Mat z = MapImage(d, both, C, [&](size_t t, int c) {
      const size_t i = t * C + c;
      const double var = r.fit.noise.Variance(c, vs.var_read[i], vs.var_shot[i], vs.radiance[i]);
      return static_cast<float>(var > 0 ? (pred[i] - vs.radiance[i]) / std::sqrt(var) : 0.0);
    });
    WriteMap(dir, stem + "_residual", z, -4.0, 4.0);
  }
}

void WriteReportPage(const fs::path& dir, const MapsResult& r) {
  EnsureDirectory(dir);
  const MapsModelInfo info = InfoOf(r.fit.model);
  std::string html =
      "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>gonio maps</title>"
      "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}img{width:256px;"
      "image-rendering:pixelated;margin:4px}td,th{padding:2px 8px;text-align:right}"
      "figure{display:inline-block;margin:4px}</style></head><body><h1>gonio maps</h1>";
  for (const auto& a : r.assumptions) html += "<p style=\"color:#b00\">Assumed: " + a + "</p>";
  for (const auto& w : r.warnings) html += "<p style=\"color:#b00\">Warning: " + w + "</p>";
  html += "<pre>" + r.Report() + "</pre><h2>Maps</h2>";
  std::vector<std::string> names;
  for (int k = 0; k < info.channel_params; ++k) names.push_back(info.channel_param_names[k]);
  names.insert(names.end(), {"normal", "height"});
  if (info.has_roughness) names.push_back("roughness");
  names.push_back("materials");
  for (int k = 0; k < info.channel_params; ++k)
    names.push_back("sd_" + info.channel_param_names[k]);
  names.push_back("sd_normal");
  if (info.has_roughness) names.push_back("sd_roughness");
  for (const auto& n : names) {
    html += "<figure><img src=\"../" + n + ".png\"><figcaption>" + n + "</figcaption></figure>";
  }
  html +=
      "<h2>Views: measured fit</h2><table><tr><th>view</th><th>texels</th><th>rms z</th>"
      "<th>relative rms</th></tr>";
  for (const auto& v : r.views) {
    html += fmt::format("<tr><td>{}</td><td>{}</td><td>{:.3f}</td><td>{:.4f}</td></tr>", v.name,
                        v.texels, v.rms_z, v.relative_rms);
  }
  html += "</table></body></html>\n";
  WriteTextAtomically(dir / "index.html", html);
}

}  // namespace

void CheckMapsOutput(const fs::path& out, const std::vector<fs::path>& inputs) {
  if (out.empty()) throw InputError("--out: empty path");
  for (const auto& in : inputs) {
    if (in.empty()) continue;
    if (IsInside(out, in) || IsInside(in, out)) {
      throw InputError(out.string() + ": the output folder would hold or replace the input " +
                       in.string());
    }
  }
  if (fs::exists(out)) {
    if (!fs::is_directory(out)) throw InputError(out.string() + ": exists and is not a folder");
    if (!fs::is_empty(out) && !fs::exists(out / "maps.json")) {
      throw InputError(out.string() +
                       ": not empty and not a previous gonio maps output (no maps.json); choose "
                       "another --out");
    }
  }
  const fs::path parent = fs::absolute(out).parent_path();
  EnsureDirectory(parent);
  if (access(parent.c_str(), W_OK) != 0) {
    throw InputError(parent.string() + ": not writable (for --out " + out.string() + ")");
  }
}

void WriteMapsOutputs(const MapsResult& r, const fs::path& out) {
  const fs::path abs = fs::absolute(out);
  const fs::path tmp = abs.parent_path() / fmt::format(".gonio-maps-tmp-{}", getpid());
  fs::remove_all(tmp);
  const TemporaryGuard guard(tmp);
  try {
    EnsureDirectory(tmp);
    WriteFittedMaps(tmp, r);
    WriteMaterials(tmp, r);
    WriteViews(tmp / "views", r);
    if (r.held_out) {
      const TexelData& d = r.data;
      const cv::Mat pred = MapImage(d, r.fit.fitted, d.channels, [&](size_t t, int c) {
        return r.held_out->prediction[t * d.channels + c];
      });
      WriteFloatTiff(tmp / "holdout_prediction.tiff", pred);
    }
    WriteReportPage(tmp / "report", r);
    nlohmann::json j = r.ToJson();
    WriteJsonAtomically(tmp / "maps.json", j);
    const fs::path old = abs.parent_path() / fmt::format(".gonio-maps-old-{}", getpid());
    if (fs::exists(abs)) fs::rename(abs, old);
    fs::rename(tmp, abs);
    fs::remove_all(old);
  } catch (...) {
    std::error_code ec;
    fs::remove_all(tmp, ec);
    throw;
  }
}

}  // namespace gonio
