#include "common/float_tiff.h"

#include <tiffio.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/io.h"

namespace fs = std::filesystem;

namespace gonio {

void WriteFloatTiff(const fs::path& path, const cv::Mat& image) {
  cv::Mat m = image;
  if (m.depth() != CV_32F) image.convertTo(m, CV_MAKETYPE(CV_32F, image.channels()));
  if (!m.isContinuous()) m = m.clone();
  WriteAtomically(path, [&](const fs::path& tmp) {
    TIFF* tif = TIFFOpen(tmp.c_str(), "w");
    if (!tif) return false;
    const int channels = m.channels();
    TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(m.cols));
    TIFFSetField(tif, TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(m.rows));
    TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, static_cast<uint16_t>(channels));
    TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, static_cast<uint16_t>(32));
    TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, static_cast<uint16_t>(SAMPLEFORMAT_IEEEFP));
    TIFFSetField(tif, TIFFTAG_PLANARCONFIG, static_cast<uint16_t>(PLANARCONFIG_CONTIG));
    TIFFSetField(tif, TIFFTAG_PHOTOMETRIC,
                 static_cast<uint16_t>(channels == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK));
    TIFFSetField(tif, TIFFTAG_COMPRESSION, static_cast<uint16_t>(COMPRESSION_NONE));
    bool ok = true;
    for (int y = 0; y < m.rows && ok; ++y) {
      ok = TIFFWriteScanline(tif, const_cast<uchar*>(m.ptr(y)), static_cast<uint32_t>(y)) == 1;
    }
    TIFFClose(tif);
    return ok;
  });
}

cv::Mat ReadFloatTiff(const fs::path& path) {
  if (!fs::exists(path)) throw InputError(path.string() + ": no such file");
  cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (m.empty() || m.depth() != CV_32F || (m.channels() != 1 && m.channels() != 3)) {
    throw InputError(path.string() + ": not a 1- or 3-channel 32-bit float TIFF");
  }
  if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2RGB);
  return m;
}

}  // namespace gonio
