// A minimal DNG writer for the RAW tests (libtiff): a CFA mosaic (any square repeat pattern,
// e.g. a 2x2 Bayer or Fujifilm's 6x6 X-Trans) or linear (demosaiced) data with one or three
// samples per pixel (PhotometricInterpretation LinearRaw, DNG spec 1.4 "LinearRaw"), with
// BlackLevel (one per sample), WhiteLevel and ExposureTime / ISO in an EXIF IFD.
#pragma once

#include <tiffio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace gonio::testing {

// PhotometricInterpretation LinearRaw (DNG spec): libtiff has no name for it.
constexpr uint16_t kPhotometricLinearRaw = 34892;

struct DngSpec {
  int width = 64, height = 48;
  // Mosaic: the repeat pattern's colours row-major ("RGGB", or 36 letters for X-Trans);
  // empty for linear data.
  std::string cfa = "RGGB";
  int linear_samples = 3;            // linear data only: 1 or 3
  std::vector<float> black = {256};  // BlackLevel: one value, or one per linear sample
  uint32_t white = 4095;
  double exposure_s = 1.0 / 125;
  int iso = 200;
  bool with_exposure = true;
  std::string make = "GonioTest", model = "DNG writer";
  // The stored value of sample `s` of pixel (photosite) (x, y).
  std::function<uint16_t(int x, int y, int s)> value;
};

// Sets a tag, passing the count first when libtiff's field definition asks for one.
template <typename T>
void SetTiffArray(TIFF* tif, uint32_t tag, const std::vector<T>& values) {
  const TIFFField* field = TIFFFindField(tif, tag, TIFF_ANY);
  ASSERT_NE(field, nullptr) << tag;
  const int ok = TIFFFieldPassCount(field)
                     ? TIFFSetField(tif, tag, static_cast<uint16_t>(values.size()), values.data())
                     : TIFFSetField(tif, tag, values.data());
  ASSERT_EQ(ok, 1) << tag;
}

inline void WriteDng(const std::filesystem::path& path, const DngSpec& spec) {
  TIFF* tif = TIFFOpen(path.c_str(), "w");
  ASSERT_NE(tif, nullptr);
  const bool mosaic = !spec.cfa.empty();
  const int samples = mosaic ? 1 : spec.linear_samples;
  TIFFSetField(tif, TIFFTAG_SUBFILETYPE, 0);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, spec.width);
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, spec.height);
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 16);
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, samples);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, mosaic ? PHOTOMETRIC_CFA : kPhotometricLinearRaw);
  TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
  TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, spec.height);
  TIFFSetField(tif, TIFFTAG_MAKE, spec.make.c_str());
  TIFFSetField(tif, TIFFTAG_MODEL, spec.model.c_str());
  SetTiffArray<uint8_t>(tif, TIFFTAG_DNGVERSION, {1, 4, 0, 0});
  if (mosaic) {
    const auto n = static_cast<uint16_t>(std::lround(std::sqrt(spec.cfa.size())));
    SetTiffArray<uint16_t>(tif, TIFFTAG_CFAREPEATPATTERNDIM, {n, n});
    // TIFF/EP colour codes: 0 red, 1 green, 2 blue, 3 cyan, 4 magenta, 5 yellow; the planes
    // are the codes in order of first appearance.
    const std::string codes = "RGBCMY";
    std::vector<uint8_t> pattern, planes;
    for (char c : spec.cfa) {
      const auto code = static_cast<uint8_t>(codes.find(c));
      if (std::find(planes.begin(), planes.end(), code) == planes.end()) planes.push_back(code);
    }
    std::sort(planes.begin(), planes.end());
    for (char c : spec.cfa) {
      const auto code = static_cast<uint8_t>(codes.find(c));
      pattern.push_back(
          static_cast<uint8_t>(std::find(planes.begin(), planes.end(), code) - planes.begin()));
    }
    SetTiffArray<uint8_t>(tif, TIFFTAG_CFAPATTERN, pattern);
    SetTiffArray<uint8_t>(tif, TIFFTAG_CFAPLANECOLOR, planes);
  }
  SetTiffArray<float>(tif, TIFFTAG_BLACKLEVEL, spec.black);
  SetTiffArray<uint32_t>(tif, TIFFTAG_WHITELEVEL, {spec.white});
  // ExposureTime and ISO go in an EXIF IFD, as cameras write them; its offset is known only
  // once it is written, so IFD0's EXIFIFD tag is written as 0 first and set to the real
  // offset afterwards (libtiff's own EXIF test does the same).
  if (spec.with_exposure) TIFFSetField(tif, TIFFTAG_EXIFIFD, uint64_t{0});
  std::vector<uint16_t> row(spec.width * samples);
  for (int y = 0; y < spec.height; ++y) {
    for (int x = 0; x < spec.width; ++x) {
      for (int s = 0; s < samples; ++s) row[x * samples + s] = spec.value(x, y, s);
    }
    ASSERT_EQ(TIFFWriteScanline(tif, row.data(), y, 0), 1);
  }
  if (spec.with_exposure) {
    ASSERT_EQ(TIFFWriteDirectory(tif), 1);
    ASSERT_EQ(TIFFCreateEXIFDirectory(tif), 0);
    ASSERT_EQ(TIFFSetField(tif, EXIFTAG_EXPOSURETIME, spec.exposure_s), 1);
    SetTiffArray<uint16_t>(tif, EXIFTAG_ISOSPEEDRATINGS, {static_cast<uint16_t>(spec.iso)});
    uint64_t exif_offset = 0;
    ASSERT_EQ(TIFFWriteCustomDirectory(tif, &exif_offset), 1);
    ASSERT_EQ(TIFFSetDirectory(tif, 0), 1);
    ASSERT_EQ(TIFFSetField(tif, TIFFTAG_EXIFIFD, exif_offset), 1);
  }
  TIFFClose(tif);
}

}  // namespace gonio::testing
