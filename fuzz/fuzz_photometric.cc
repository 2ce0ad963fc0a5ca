// photometric.json (calib/photometry/photometric.h, PhotometricCalibration::Read): an accepted
// calibration has a finite, non-negative read noise, a positive electrons-per-DN when given,
// a vignetting map (when there is one) of finite positive values, and a radial V's response
// kernel (when there is one) of finite weights, one per raw value >= 0.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/photometric.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // The vignetting map the seeds name (a small valid one), so inputs get past reading it.
  cv::Mat map(24, 32, CV_32F, cv::Scalar(0.9f));
  cv::imwrite((gonio::fuzz::WorkDir() / "photometric_vignette.tiff").string(), map);
  // V's input raw values: 2 x 2 cells of 16 px cover the map.
  cv::Mat input(2, 2, CV_32F, cv::Scalar(1000.0f));
  cv::imwrite((gonio::fuzz::WorkDir() / "photometric_vignette_input.tiff").string(), input);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using gonio::fuzz::Finite;
  return gonio::fuzz::Run([&] {
    const auto path = gonio::fuzz::WriteInput(data, size, "photometric.json");
    const gonio::PhotometricCalibration c = gonio::PhotometricCalibration::Read(path);
    GONIO_FUZZ_REQUIRE(Finite(c.read_noise_dn) && c.read_noise_dn >= 0);
    if (c.electrons_per_dn)
      GONIO_FUZZ_REQUIRE(Finite(*c.electrons_per_dn) && *c.electrons_per_dn > 0);
    if (!c.vignette.empty()) {
      double lo, hi;
      cv::minMaxLoc(c.vignette, &lo, &hi);
      GONIO_FUZZ_REQUIRE(cv::checkRange(c.vignette) && lo > 0);
    }
    const gonio::VignetteResponseKernel& k = c.vignette_response_kernel;
    GONIO_FUZZ_REQUIRE(k.weight.size() == k.raw.size());
    for (size_t b = 0; b < k.raw.size(); ++b) {
      GONIO_FUZZ_REQUIRE(Finite(k.raw[b]) && k.raw[b] >= 0);
      for (double w : k.weight[b]) GONIO_FUZZ_REQUIRE(Finite(w));
    }
    for (int j = 0; j < 3; ++j) GONIO_FUZZ_REQUIRE(Finite(k.v[j]) && Finite(k.truncation[j]));
    GONIO_FUZZ_REQUIRE(Finite(k.covered_radius) && k.covered_radius >= 0);
    const nlohmann::json response = c.response.ToJson();
    (void)response;
  });
}
