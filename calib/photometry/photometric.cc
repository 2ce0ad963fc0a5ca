#include "calib/photometry/photometric.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/parallel.h"
#include "common/stats.h"

namespace gonio {

PhotometricCalibration PhotometricCalibration::Linear(int bit_depth, int channels,
                                                      double black_level, BlackLevelSource source) {
  PhotometricCalibration p;
  ResponseResult& r = p.response;
  r.black_level_source = source;
  r.bit_depth = bit_depth;
  r.channels = channels;
  const int n = 1 << bit_depth;
  r.black_level.assign(channels, black_level);
  r.saturation_level.assign(channels, n - 1.0);
  r.inverse_response.assign(channels, std::vector<double>(n));
  for (int c = 0; c < channels; ++c) {
    for (int z = 0; z < n; ++z) {
      r.inverse_response[c][z] = std::max(0.0, (z - black_level) / (n - 1.0 - black_level));
    }
  }
  return p;
}

void PhotometricCalibration::ToRadiance(const cv::Mat& raw, double exposure_s, double gain,
                                        cv::Mat* radiance, cv::Mat* variance, cv::Mat* valid,
                                        int threads) const {
  const int channels = raw.channels();
  if (channels != response.channels) {
    throw InputError("image has " + std::to_string(channels) +
                     " channels, the photometric calibration " + std::to_string(response.channels));
  }
  if (!vignette.empty() && vignette.size() != raw.size()) {
    throw InputError(fmt::format("image is {}x{}, the vignetting map {} is {}x{}", raw.cols,
                                 raw.rows, vignette_file.string(), vignette.cols, vignette.rows));
  }
  if (!(exposure_s > 0) || !(gain > 0)) throw InputError("exposure and gain must be > 0");
  const double max_value = (1 << response.bit_depth) - 1.0;
  *radiance = cv::Mat(raw.size(), CV_MAKETYPE(CV_32F, channels));
  *variance = cv::Mat(raw.size(), CV_MAKETYPE(CV_32F, channels));
  *valid = cv::Mat(raw.size(), CV_8U, cv::Scalar(1));
  // One row at a time through a row buffer: converting the whole frame to doubles first
  // allocated 8 bytes per sample per frame, and its page faults were about a fifth of `gonio
  // run` on an RGB session (the textured preset at 1280x960: extraction 6.0 s, 3.1 s without;
  // docs/maps.md "Full size").
  ParallelFor(raw.rows, threads, [&](size_t row_begin, size_t row_end) {
    cv::Mat values(1, raw.cols, CV_MAKETYPE(CV_64F, channels));
    for (int y = static_cast<int>(row_begin); y < static_cast<int>(row_end); ++y) {
      raw.row(y).convertTo(values, CV_MAKETYPE(CV_64F, channels));
      const double* in = values.ptr<double>(0);
      float* out = radiance->ptr<float>(y);
      float* var = variance->ptr<float>(y);
      uint8_t* ok = valid->ptr<uint8_t>(y);
      for (int x = 0; x < raw.cols; ++x) {
        const double v = vignette.empty() ? 1.0 : vignette.at<float>(y, x);
        const double scale = 1.0 / (exposure_s * gain * v);
        for (int c = 0; c < channels; ++c) {
          const double z = in[x * channels + c];
          if (z >= std::min(max_value, response.saturation_level[c]) ||
              z <= response.black_level[c] + 0.5) {
            ok[x] = 0;
          }
          const double slope = response.Slope(c, z);
          double var_z = 1.0 / 12.0 + read_noise_dn * read_noise_dn;
          if (electrons_per_dn)
            var_z += std::max(0.0, z - response.black_level[c]) / *electrons_per_dn;
          out[x * channels + c] = static_cast<float>(response.Linearize(c, z) * scale);
          var[x * channels + c] = static_cast<float>(slope * slope * var_z * scale * scale);
        }
      }
    }
  });
}

PhotometricCalibration PhotometricCalibration::AssumedLinearFor(const Session& session,
                                                                std::string* assumption) {
  if (session.frames.empty()) throw InputError(session.dir.string() + ": no frames");
  const cv::Mat first = ReadImage(session.FramePath(0), ImageExpectation());
  const int bits = session.bit_depth > 0 ? session.bit_depth : (first.depth() == CV_8U ? 8 : 16);
  *assumption = fmt::format(
      "no photometric calibration: a linear camera with black level 0 and no vignetting ({} "
      "bit) was assumed (--assume-linear)",
      bits);
  return Linear(bits, first.channels(), 0.0, BlackLevelSource::kAssumed);
}

double PhotometricCalibration::CombinedAccuracy(const ResponseResult& response,
                                                double vignette_rms_relative) {
  return std::min(
      std::sqrt(std::pow(ResponseAccuracy(response), 2) + std::pow(SmoothingError(response), 2) +
                vignette_rms_relative * vignette_rms_relative),
      0.99);
}

double PhotometricCalibration::ResponseFieldRms(const ResponseResult& response) {
  double sum = 0;
  int n = 0;
  for (double b : response.consistency.band_bias) {
    if (std::isfinite(b)) sum += b * b, ++n;
  }
  return n > 0 ? std::min(std::sqrt(sum / n), 0.99) : ResponseAccuracy(response);
}

namespace {

// How many of `values` (raw pixel values) fall in each of `n` equal parts of the consistency's
// value range (values beyond it in the outer parts); empty without values, parts or range.
std::vector<double> ValuesPerBand(const PairConsistency& c, int n,
                                  const std::vector<double>& values) {
  const double width = (c.range_hi - c.range_lo) / std::max(n, 1);
  if (values.empty() || n == 0 || !(width > 0)) return {};
  std::vector<double> count(n, 0.0);
  for (double z : values) {
    ++count[std::clamp(static_cast<int>(std::floor((z - c.range_lo) / width)), 0, n - 1)];
  }
  return count;
}

// The RMS over `values` (raw pixel values) of the figure of the self-check's band each falls in
// (`bands` over the consistency's value range in equal parts; a band without a figure counts as
// `missing`, values beyond the range as the outer bands); `fallback` without bands or values.
double BandRmsAt(const PairConsistency& c, const std::vector<double>& bands, double missing,
                 const std::vector<double>& values, double fallback) {
  const std::vector<double> count = ValuesPerBand(c, static_cast<int>(bands.size()), values);
  if (count.empty()) return fallback;
  double sum = 0;
  for (size_t b = 0; b < bands.size(); ++b) {
    const double f = std::isfinite(bands[b]) ? bands[b] : missing;
    sum += count[b] * f * f;
  }
  return std::min(std::sqrt(sum / values.size()), 0.99);
}

}  // namespace

double PhotometricCalibration::ResponseFieldRmsAt(const ResponseResult& response,
                                                  const std::vector<double>& values) {
  return BandRmsAt(response.consistency, response.consistency.band_bias, ResponseAccuracy(response),
                   values, ResponseFieldRms(response));
}

double PhotometricCalibration::ResponseTrendAt(const ResponseResult& response,
                                               const std::vector<double>& values) {
  const PairConsistency& c = response.consistency;
  const int n = static_cast<int>(c.band_bias.size());
  const std::vector<double> count = ValuesPerBand(c, n, values);
  if (count.empty()) return ResponseFieldRms(response);
  double finite = 0, mean = 0;
  for (int b = 0; b < n; ++b) {
    if (std::isfinite(c.band_bias[b])) finite += count[b], mean += count[b] * c.band_bias[b];
  }
  const double missing = ResponseAccuracy(response);
  const double total = static_cast<double>(values.size());
  if (finite == 0) return std::min(missing, 0.99);
  mean /= finite;
  double scatter = 0, share_squares = 0;
  for (int b = 0; b < n; ++b) {
    if (!std::isfinite(c.band_bias[b])) continue;
    const double share = count[b] / finite;
    scatter += share * (c.band_bias[b] - mean) * (c.band_bias[b] - mean);
    share_squares += share * share;
  }
  // The mean's variance: the scatter over the bands' effective number, 1 / sum of share^2.
  const double common = mean * mean + scatter * share_squares;
  return std::min(std::sqrt((finite * common + (total - finite) * missing * missing) / total),
                  0.99);
}

double PhotometricCalibration::ResponseSlopeErrorAt(const ResponseResult& response,
                                                    const std::vector<double>& values) {
  return std::min(ResponseTrendAt(response, values) / ExposureStepOctaves(response), 0.99);
}

double PhotometricCalibration::SmoothingSensitivityAt(const ResponseResult& response,
                                                      const std::vector<double>& values) {
  return BandRmsAt(response.consistency, response.smoothing_sensitivity_bands,
                   SmoothingError(response), values, SmoothingError(response));
}

std::optional<std::string> PhotometricCalibration::PriorHeldWarning(
    const ResponseResult& response, const std::vector<double>& values) {
  const double moved = SmoothingSensitivityAt(response, values);
  if (moved > 0) {
    spdlog::info(
        "response: {:.2f}% under a {:.0f}x stiffer prior where the sample's values are "
        "(a warning above {:.1f}%)",
        100 * moved, kSmoothingSensitivityFactor, 100 * kPriorHeldLimitAtValues);
  }
  if (!(moved > kPriorHeldLimitAtValues)) return std::nullopt;
  return fmt::format(
      "the response calibration limits the result: where the sample's values are, its curve "
      "moves {:.1f}% under a {:.0f}x stiffer prior (more than {:.1f}%), so between the sweep's "
      "exposures it is the prior's guess, an error every observation at a value shares (the "
      "error bars draw it from that figure); narrowed by {} (docs/capture-guide.md)",
      100 * moved, kSmoothingSensitivityFactor, 100 * kPriorHeldLimitAtValues,
      SweepRemedy(ExposurePeriodOctaves(response)));
}

double PhotometricCalibration::SmoothingError(const ResponseResult& response) {
  const double s = response.smoothing_sensitivity;
  return std::isfinite(s) ? std::min(s, 0.99) : 0.0;
}

double PhotometricCalibration::ResponseAccuracy(const ResponseResult& response) {
  const PairConsistency& c = response.consistency;
  if (std::isfinite(c.worst_band_bias)) return std::min(std::abs(c.worst_band_bias), 0.99);
  if (std::isfinite(c.median_pair)) return std::min(std::abs(c.median_pair), 0.99);
  return 0;
}

namespace {

// photometric.json's "vignette_input" "response_kernel" (docs/formats.md).
void ReadResponseKernel(const std::string& where, const nlohmann::json& j,
                        PhotometricCalibration* p) {
  const std::string what = where +
                           ": 'response_kernel' must be {\"v\": [3 numbers], \"raw\": "
                           "[numbers >= 0], \"weight\": [[3 numbers] per raw value], optionally "
                           "\"truncation\": [3 numbers] with \"covered_radius\": number >= 0}";
  const auto finite = [](const nlohmann::json& x) {
    return x.is_number() && std::isfinite(x.get<double>());
  };
  const auto triple = [&](const nlohmann::json& x) {
    return x.is_array() && x.size() == 3 && std::all_of(x.begin(), x.end(), finite);
  };
  if (!j.is_object() || !j.contains("v") || !triple(j["v"]) || !j.contains("raw") ||
      !j["raw"].is_array() || !j.contains("weight") || !j["weight"].is_array() ||
      j["weight"].size() != j["raw"].size()) {
    throw InputError(what);
  }
  VignetteResponseKernel k;
  k.v = j["v"].get<std::array<double, 3>>();
  // The truncation and its radius (written since they were measured; absent: none).
  if (j.contains("truncation") || j.contains("covered_radius")) {
    if (!j.contains("truncation") || !triple(j["truncation"]) || !j.contains("covered_radius") ||
        !finite(j["covered_radius"]) || j["covered_radius"].get<double>() < 0) {
      throw InputError(what);
    }
    k.truncation = j["truncation"].get<std::array<double, 3>>();
    k.covered_radius = j["covered_radius"].get<double>();
  }
  for (size_t b = 0; b < j["raw"].size(); ++b) {
    const auto& raw = j["raw"][b];
    if (!finite(raw) || raw.get<double>() < 0 || !triple(j["weight"][b])) throw InputError(what);
    k.raw.push_back(raw.get<double>());
    k.weight.push_back(j["weight"][b].get<std::array<double, 3>>());
  }
  p->vignette_response_kernel = std::move(k);
}

// photometric.json's "vignette_input" (docs/formats.md): the raw values V was measured from,
// on a grid of cell_px cells covering the vignetting map; NaN where V had no sample.
void ReadVignetteInput(const std::filesystem::path& path, const nlohmann::json& j,
                       PhotometricCalibration* p) {
  const std::string where = path.string() + ": 'vignette_input'";
  if (!j.is_object() || !j.contains("raw_values") || !j["raw_values"].is_string() ||
      !j.contains("cell_px") || !j["cell_px"].is_number_integer() || j["cell_px"].get<int>() < 1) {
    throw InputError(where + " must be {\"raw_values\": file, \"cell_px\": integer >= 1}");
  }
  if (p->vignette.empty()) throw InputError(where + " needs a 'vignette' map");
  const auto file = path.parent_path() / j["raw_values"].get<std::string>();
  ImageExpectation expect;
  expect.pixels = ImageExpectation::Pixels::kFloat;
  expect.channels = 1;
  expect.channels_of = "the vignetting's input raw values";
  const cv::Mat raw = ReadImage(file, expect);
  const int cell = j["cell_px"].get<int>();
  const auto covers = [&](int cells, int pixels) {
    return cells * cell >= pixels && (cells - 1) * cell < pixels;
  };
  if (!covers(raw.cols, p->vignette.cols) || !covers(raw.rows, p->vignette.rows)) {
    throw InputError(fmt::format("{}: {}x{} cells of {} px do not cover the {}x{} vignetting map",
                                 file.string(), raw.cols, raw.rows, cell, p->vignette.cols,
                                 p->vignette.rows));
  }
  for (int y = 0; y < raw.rows; ++y) {
    for (int x = 0; x < raw.cols; ++x) {
      const float v = raw.at<float>(y, x);
      if (std::isinf(v) || v < 0) {
        throw InputError(file.string() + ": raw values must be >= 0 (NaN: no sample)");
      }
    }
  }
  p->vignette_input_raw = raw;
  p->vignette_input_cell_px = cell;
  if (j.contains("response_kernel")) ReadResponseKernel(where, j["response_kernel"], p);
}

}  // namespace

PhotometricCalibration PhotometricCalibration::Read(const std::filesystem::path& path) {
  const nlohmann::json j = ReadJsonFile(path);
  PhotometricCalibration p;
  if (!j.contains("response")) throw InputError(path.string() + ": missing key 'response'");
  p.response = ResponseResult::FromJson(j["response"], path.string());
  // The noise terms enter a variance and a division (docs/formats.md): a wrong type or sign
  // is bad input, never a NaN later.
  if (j.contains("read_noise_dn")) {
    const auto& v = j["read_noise_dn"];
    if (!v.is_number() || !(v.get<double>() >= 0) || !std::isfinite(v.get<double>())) {
      throw InputError(path.string() + ": 'read_noise_dn' must be a number >= 0");
    }
    p.read_noise_dn = v.get<double>();
  }
  if (j.contains("electrons_per_dn") && !j["electrons_per_dn"].is_null()) {
    const auto& v = j["electrons_per_dn"];
    if (!v.is_number() || !(v.get<double>() > 0) || !std::isfinite(v.get<double>())) {
      throw InputError(path.string() + ": 'electrons_per_dn' must be a number > 0 or null");
    }
    p.electrons_per_dn = v.get<double>();
  }
  if (j.contains("relative_accuracy") && !j["relative_accuracy"].is_null()) {
    const auto& v = j["relative_accuracy"];
    if (!v.is_number() || !(v.get<double>() >= 0 && v.get<double>() < 1)) {
      throw InputError(path.string() + ": 'relative_accuracy' must be a number in [0, 1) or null");
    }
    p.relative_accuracy = v.get<double>();
  }
  if (j.contains("vignette") && !j["vignette"].is_null()) {
    if (!j["vignette"].is_string()) {
      throw InputError(path.string() + ": 'vignette' must be a file name or null");
    }
    const auto file = path.parent_path() / j["vignette"].get<std::string>();
    ImageExpectation expect;
    expect.pixels = ImageExpectation::Pixels::kFloat;
    expect.channels = 1;
    expect.channels_of = "a vignetting map";
    p.vignette = ReadImage(file, expect);
    p.vignette_file = file;
    // V(x) divides the radiance: zeros, negatives, NaN or Inf would give Inf/NaN radiance.
    double lo = 0, hi = 0;
    if (!cv::checkRange(p.vignette)) {
      throw InputError(file.string() + ": the vignetting map holds NaN or Inf");
    }
    cv::minMaxLoc(p.vignette, &lo, &hi);
    if (!(lo > 0)) {
      throw InputError(file.string() + ": the vignetting map holds values <= 0 (min " +
                       std::to_string(lo) + "); V(x) must be positive everywhere");
    }
  }
  if (j.contains("vignette_input") && !j["vignette_input"].is_null()) {
    ReadVignetteInput(path, j["vignette_input"], &p);
  }
  if (!(p.read_noise_dn >= 0) || !std::isfinite(p.read_noise_dn)) {
    throw InputError(path.string() + ": read_noise_dn must be a finite number >= 0");
  }
  if (p.electrons_per_dn && !(*p.electrons_per_dn > 0 && std::isfinite(*p.electrons_per_dn))) {
    throw InputError(path.string() + ": electrons_per_dn must be a finite number > 0");
  }
  return p;
}

void PhotometricCalibration::Write(const std::filesystem::path& path) const {
  nlohmann::json j;
  j["response"] = response.ToJson();
  j["read_noise_dn"] = read_noise_dn;
  j["electrons_per_dn"] = electrons_per_dn ? nlohmann::json(*electrons_per_dn) : nlohmann::json();
  j["relative_accuracy"] =
      relative_accuracy ? nlohmann::json(*relative_accuracy) : nlohmann::json();
  if (!vignette.empty()) {
    const std::string name = path.stem().string() + "_vignette.tiff";
    WriteImage(path.parent_path() / name, vignette);
    j["vignette"] = name;
    if (!vignette_input_raw.empty()) {
      const std::string input = path.stem().string() + "_vignette_input.tiff";
      WriteImage(path.parent_path() / input, vignette_input_raw);
      j["vignette_input"] = {{"raw_values", input}, {"cell_px", vignette_input_cell_px}};
      if (!vignette_response_kernel.empty()) {
        const VignetteResponseKernel& k = vignette_response_kernel;
        j["vignette_input"]["response_kernel"] = {{"v", k.v},
                                                  {"truncation", k.truncation},
                                                  {"covered_radius", k.covered_radius},
                                                  {"raw", k.raw},
                                                  {"weight", k.weight}};
      }
    }
  } else {
    j["vignette"] = nullptr;
  }
  WriteJsonAtomically(path, j);
}

}  // namespace gonio
