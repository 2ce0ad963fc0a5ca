#include "capture/interactive.h"

#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <string>

#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>

#include "capture/bracket.h"

namespace gonio::capture {

bool HaveDisplay() {
  for (const char* var : {"DISPLAY", "WAYLAND_DISPLAY"}) {
    const char* v = std::getenv(var);
    if (v != nullptr && *v != '\0') return true;
  }
  return false;
}

BeforeBracket InteractiveBeforeBracket(FrameSource& source, const BracketOptions& options) {
  if (!HaveDisplay()) return PromptBeforeBracket(std::cin, std::cerr, options.brackets);
  std::vector<double> sorted = options.exposures_s;
  std::sort(sorted.begin(), sorted.end());
  const double preview_exposure = sorted[sorted.size() / 2];
  return [&source, &options, preview_exposure](int bracket) {
    const std::string window = "gonio capture";
    cv::namedWindow(window, cv::WINDOW_NORMAL);
    source.SetExposure(preview_exposure, options.gain);
    for (;;) {
      std::optional<CapturedFrame> frame = source.Grab();
      if (!frame) return false;
      cv::Mat shown = frame->image;
      if (shown.depth() == CV_16U) shown.convertTo(shown, CV_8U, 1.0 / 256.0);
      if (shown.channels() == 1) cv::cvtColor(shown, shown, cv::COLOR_GRAY2BGR);
      const std::string text = "bracket " + std::to_string(bracket + 1) + "/" +
                               std::to_string(options.brackets) + ": SPACE capture, Q stop (" +
                               FormatDuration(frame->exposure_s) + ")";
      cv::putText(shown, text, {10, 30}, cv::FONT_HERSHEY_SIMPLEX, 0.8, {0, 255, 0}, 2);
      cv::imshow(window, shown);
      const int key = cv::waitKey(1) & 0xff;
      if (key == ' ' || key == 13 || key == 10) return true;
      if (key == 'q' || key == 'Q' || key == 27) {
        cv::destroyWindow(window);
        return false;
      }
    }
  };
}

}  // namespace gonio::capture
