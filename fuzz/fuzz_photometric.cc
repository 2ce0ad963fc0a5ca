// photometric.json (calib/photometry/photometric.h, PhotometricCalibration::Read): an accepted
// calibration has a finite, non-negative read noise, a positive electrons-per-DN when given,
// and a vignetting map (when there is one) of finite positive values.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/photometry/photometric.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // The vignetting map the seeds name (a small valid one), so inputs get past reading it.
  cv::Mat map(24, 32, CV_32F, cv::Scalar(0.9f));
  cv::imwrite((gonio::fuzz::WorkDir() / "photometric_vignette.tiff").string(), map);
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
    const nlohmann::json response = c.response.ToJson();
    (void)response;
  });
}
