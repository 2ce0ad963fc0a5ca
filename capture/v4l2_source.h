// Video4Linux2 cameras (webcams, UVC and most single-node capture devices): capability query,
// format and frame-size enumeration, format negotiation, mmap streaming through a ring of
// buffers, manual exposure and gain with per-frame read-back. Device access goes through
// libv4l2 with its format conversion disabled, so frames arrive in the device's own format
// (libv4l2 still loads the plugins some cameras need).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture/frame_source.h"
#include "capture/pixel_format.h"

namespace gonio::capture {

struct V4l2ControlRange {
  int32_t min = 0, max = 0, step = 1, default_value = 0;
};

struct V4l2DeviceInfo {
  std::string path, driver, card, bus_info;
  bool is_capture = false;  // single-planar video capture with streaming I/O
  std::string not_capture_reason;
  std::vector<FormatOption> formats;               // formats gonio converts
  std::vector<uint32_t> fourccs;                   // the device's own fourcc for each of formats
  std::vector<std::string> unsupported_formats;    // fourccs it cannot (listed for the user)
  std::optional<V4l2ControlRange> exposure_100us;  // V4L2_CID_EXPOSURE_ABSOLUTE
  std::optional<V4l2ControlRange> gain;            // V4L2_CID_ANALOGUE_GAIN or V4L2_CID_GAIN
  nlohmann::json ToJson() const;
};

// /dev/video* nodes sorted by number (video2 before video10).
std::vector<std::string> ListVideoNodes();

// Opens the node, queries it and closes it. InputError "PATH: cannot open (reason)" when the
// node cannot be opened or is not a V4L2 device.
V4l2DeviceInfo QueryV4l2Device(const std::string& path);

// A frame-period range in seconds as VIDIOC_ENUM_FRAMEINTERVALS reports it (discrete: min ==
// max).
struct PeriodRange {
  double min_s = 0.0, max_s = 0.0;
};
// The frame period to ask for so the longest exposure fits in one frame: the shortest offered
// period >= longest_exposure_s (the highest frame rate that still allows it), or the longest
// offered when none is long enough (the device then clips long exposures; the per-frame
// read-back shows it). 0 when nothing is offered.
double ChooseFramePeriod(const std::vector<PeriodRange>& offered, double longest_exposure_s);

// The V4L2 fourcc code for a layout and back (nullopt for fourccs gonio does not convert).
uint32_t V4l2Fourcc(PixelLayout layout);
std::optional<PixelLayout> LayoutFromV4l2Fourcc(uint32_t fourcc);
std::string FourccToString(uint32_t fourcc);

class V4l2Source : public FrameSource {
 public:
  struct Options {
    std::string device = "/dev/video0";
    FormatRequest format;
    int buffers = 4;         // ring of mmap buffers
    int settle_frames = -1;  // frames dropped after a control change; -1: buffers + 2
    // The frame period is chosen so this exposure fits (0: keep the driver's default rate).
    // Set before streaming because drivers refuse VIDIOC_S_PARM while streaming.
    double longest_exposure_s = 0.0;
    void Check() const;
  };

  // Opens, negotiates the format, maps the buffers and starts streaming. InputError naming the
  // device when it cannot be opened, is not a capture device or refuses the format.
  explicit V4l2Source(const Options& options);
  ~V4l2Source() override;
  V4l2Source(const V4l2Source&) = delete;
  V4l2Source& operator=(const V4l2Source&) = delete;

  std::string Id() const override;
  std::string GainUnit() const override;
  bool ControlsExposure() const override { return true; }
  // Exposure goes through V4L2_CID_EXPOSURE_ABSOLUTE (units of 100 us, so it is the only
  // control whose unit is known); gain through V4L2_CID_ANALOGUE_GAIN or V4L2_CID_GAIN in the
  // driver's units (unset: the control's minimum). Auto exposure, auto gain and auto white
  // balance are switched off where the device has them.
  void SetExposure(double exposure_s, std::optional<double> gain) override;
  void Settle() override;
  std::optional<CapturedFrame> Grab() override;

  const ChosenFormat& format() const { return format_; }
  const V4l2DeviceInfo& info() const { return info_; }

 private:
  struct Buffer {
    void* start = nullptr;
    size_t length = 0;
  };
  void Ioctl(unsigned long request, void* arg, const char* what) const;
  bool TrySetControl(uint32_t id, int32_t value);
  int32_t GetControl(uint32_t id) const;
  void SetFramePeriod(uint32_t fourcc);
  void StartStreaming();
  void StopStreaming();

  Options options_;
  V4l2DeviceInfo info_;
  int fd_ = -1;
  ChosenFormat format_{};
  size_t stride_ = 0;
  std::vector<Buffer> buffers_;
  bool streaming_ = false;
  uint32_t gain_control_ = 0;
  bool manual_set_ = false;
  double last_exposure_s_ = 0.0;
};

}  // namespace gonio::capture
