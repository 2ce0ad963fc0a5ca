#include "capture/v4l2_source.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include <fcntl.h>
#include <libv4l2.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include "capture/bracket.h"
#include "common/error.h"
#include "common/log.h"
#include "common/session.h"

namespace fs = std::filesystem;

namespace gonio::capture {
namespace {

constexpr double kExposureUnitS = 100e-6;  // V4L2_CID_EXPOSURE_ABSOLUTE counts 100 us

struct FourccLayout {
  uint32_t fourcc;
  PixelLayout layout;
};
constexpr FourccLayout kFourccs[] = {
    {V4L2_PIX_FMT_GREY, PixelLayout::kGrey},   {V4L2_PIX_FMT_Y10, PixelLayout::kY10},
    {V4L2_PIX_FMT_Y12, PixelLayout::kY12},     {V4L2_PIX_FMT_Y16, PixelLayout::kY16},
    {V4L2_PIX_FMT_YUYV, PixelLayout::kYuyv},   {V4L2_PIX_FMT_NV12, PixelLayout::kNv12},
    {V4L2_PIX_FMT_MJPEG, PixelLayout::kMjpeg}, {V4L2_PIX_FMT_JPEG, PixelLayout::kMjpeg},
    {V4L2_PIX_FMT_BGR24, PixelLayout::kBgr24}, {V4L2_PIX_FMT_RGB24, PixelLayout::kRgb24},
};

// ioctl through libv4l2, retried when a signal interrupts it.
int Xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do {
    r = v4l2_ioctl(fd, request, arg);
  } while (r == -1 && errno == EINTR);
  return r;
}

// Opens a node with libv4l2's conversion disabled: photometry needs the device's own bytes.
// Returns -1 with errno set on failure.
int OpenDevice(const std::string& path) {
  const int raw = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (raw < 0) return -1;
  // Ask the kernel first: libv4l2 prints its own complaint to stderr for non-V4L2 files, and
  // gonio's errors are one line.
  v4l2_capability cap{};
  if (::ioctl(raw, VIDIOC_QUERYCAP, &cap) != 0) {
    ::close(raw);
    errno = ENOTTY;
    return -1;
  }
  const int fd = v4l2_fd_open(raw, V4L2_DISABLE_CONVERSION);
  if (fd < 0) {
    const int e = errno;
    ::close(raw);
    errno = e;
    return -1;
  }
  return fd;
}

// Why OpenDevice failed, from errno.
std::string OpenErrorText() {
  if (errno == ENOTTY) return "not a V4L2 device";
  if (errno == EACCES) return std::string(std::strerror(errno)) + "; is the user in group video?";
  return std::strerror(errno);
}

std::optional<v4l2_queryctrl> QueryControl(int fd, uint32_t id) {
  v4l2_queryctrl q{};
  q.id = id;
  if (Xioctl(fd, VIDIOC_QUERYCTRL, &q) != 0) return std::nullopt;
  if (q.flags & V4L2_CTRL_FLAG_DISABLED) return std::nullopt;
  return q;
}

std::optional<V4l2ControlRange> ControlRange(int fd, uint32_t id) {
  const auto q = QueryControl(fd, id);
  if (!q || (q->flags & V4L2_CTRL_FLAG_READ_ONLY)) return std::nullopt;
  return V4l2ControlRange{q->minimum, q->maximum, std::max(1, q->step), q->default_value};
}

bool MenuHasItem(int fd, uint32_t id, uint32_t index) {
  v4l2_querymenu m{};
  m.id = id;
  m.index = index;
  return Xioctl(fd, VIDIOC_QUERYMENU, &m) == 0;
}

std::vector<SizeRange> FrameSizes(int fd, uint32_t fourcc) {
  std::vector<SizeRange> sizes;
  for (uint32_t i = 0;; ++i) {
    v4l2_frmsizeenum fs{};
    fs.index = i;
    fs.pixel_format = fourcc;
    if (Xioctl(fd, VIDIOC_ENUM_FRAMESIZES, &fs) != 0) break;
    if (fs.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
      const int w = static_cast<int>(fs.discrete.width), h = static_cast<int>(fs.discrete.height);
      sizes.push_back({w, w, 1, h, h, 1});
    } else {
      // Stepwise and continuous ranges come as a single entry (index 0).
      const auto& s = fs.stepwise;
      sizes.push_back({static_cast<int>(s.min_width), static_cast<int>(s.max_width),
                       static_cast<int>(std::max(1u, s.step_width)), static_cast<int>(s.min_height),
                       static_cast<int>(s.max_height),
                       static_cast<int>(std::max(1u, s.step_height))});
      break;
    }
  }
  return sizes;
}

void FillInfo(int fd, V4l2DeviceInfo& info) {
  v4l2_capability cap{};
  if (Xioctl(fd, VIDIOC_QUERYCAP, &cap) != 0) {
    throw InputError(info.path + ": cannot open (not a V4L2 device: " + std::strerror(errno) + ")");
  }
  info.driver = reinterpret_cast<const char*>(cap.driver);
  info.card = reinterpret_cast<const char*>(cap.card);
  info.bus_info = reinterpret_cast<const char*>(cap.bus_info);
  // device_caps describes this node; capabilities the whole physical device.
  const uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) {
    info.not_capture_reason = (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE)
                                  ? "multi-planar capture node (use --backend libcamera)"
                              : (caps & V4L2_CAP_META_CAPTURE) ? "metadata node, not video"
                                                               : "not a video capture node";
    return;
  }
  if (!(caps & V4L2_CAP_STREAMING)) {
    info.not_capture_reason = "no streaming I/O";
    return;
  }
  info.is_capture = true;
  for (uint32_t i = 0;; ++i) {
    v4l2_fmtdesc d{};
    d.index = i;
    d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (Xioctl(fd, VIDIOC_ENUM_FMT, &d) != 0) break;
    const auto layout = LayoutFromV4l2Fourcc(d.pixelformat);
    if (!layout) {
      info.unsupported_formats.push_back(FourccToString(d.pixelformat));
      continue;
    }
    // JPEG and MJPG are the same to gonio; keep the first.
    const bool seen = std::any_of(info.formats.begin(), info.formats.end(),
                                  [&](const FormatOption& o) { return o.layout == *layout; });
    if (!seen) {
      info.formats.push_back({*layout, FrameSizes(fd, d.pixelformat)});
      info.fourccs.push_back(d.pixelformat);
    }
  }
  info.exposure_100us = ControlRange(fd, V4L2_CID_EXPOSURE_ABSOLUTE);
  info.gain = ControlRange(fd, V4L2_CID_ANALOGUE_GAIN);
  if (!info.gain) info.gain = ControlRange(fd, V4L2_CID_GAIN);
}

std::string ErrnoText(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

double ChooseFramePeriod(const std::vector<PeriodRange>& offered, double longest_exposure_s) {
  double best = 0.0, longest = 0.0;
  for (const PeriodRange& r : offered) {
    longest = std::max(longest, r.max_s);
    if (r.max_s >= longest_exposure_s) {
      const double candidate = std::max(r.min_s, longest_exposure_s);
      if (best == 0.0 || candidate < best) best = candidate;
    }
  }
  return best > 0.0 ? best : longest;
}

uint32_t V4l2Fourcc(PixelLayout layout) {
  for (const auto& f : kFourccs) {
    if (f.layout == layout) return f.fourcc;
  }
  return 0;
}

std::optional<PixelLayout> LayoutFromV4l2Fourcc(uint32_t fourcc) {
  for (const auto& f : kFourccs) {
    if (f.fourcc == fourcc) return f.layout;
  }
  return std::nullopt;
}

std::string FourccToString(uint32_t fourcc) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((fourcc >> (8 * i)) & 0xff);
    if (c != ' ' && c != '\0') s += c;
  }
  return s;
}

nlohmann::json V4l2DeviceInfo::ToJson() const {
  nlohmann::json j = {{"backend", "v4l2"},
                      {"device", path},
                      {"driver", driver},
                      {"card", card},
                      {"bus_info", bus_info}};
  nlohmann::json fmts = nlohmann::json::array();
  for (const auto& f : formats) {
    nlohmann::json sizes = nlohmann::json::array();
    for (const auto& s : f.sizes) sizes.push_back(s.ToString());
    fmts.push_back({{"format", LayoutName(f.layout)}, {"sizes", sizes}});
  }
  j["formats"] = fmts;
  j["unsupported_formats"] = unsupported_formats;
  if (exposure_100us) {
    j["exposure_range_s"] = {exposure_100us->min * kExposureUnitS,
                             exposure_100us->max * kExposureUnitS};
  } else {
    j["exposure_range_s"] = nullptr;
  }
  if (gain) {
    j["gain_range"] = {gain->min, gain->max};
  } else {
    j["gain_range"] = nullptr;
  }
  return j;
}

std::vector<std::string> ListVideoNodes() {
  std::vector<std::pair<long, std::string>> nodes;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/dev", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("video", 0) != 0 || name.size() == 5) continue;
    const std::string digits = name.substr(5);
    if (!std::all_of(digits.begin(), digits.end(), ::isdigit)) continue;
    nodes.emplace_back(std::stol(digits), entry.path().string());
  }
  std::sort(nodes.begin(), nodes.end());
  std::vector<std::string> out;
  for (const auto& n : nodes) out.push_back(n.second);
  return out;
}

V4l2DeviceInfo QueryV4l2Device(const std::string& path) {
  V4l2DeviceInfo info;
  info.path = path;
  const int fd = OpenDevice(path);
  if (fd < 0) throw InputError(path + ": cannot open (" + OpenErrorText() + ")");
  try {
    FillInfo(fd, info);
  } catch (...) {
    v4l2_close(fd);
    throw;
  }
  v4l2_close(fd);
  return info;
}

void V4l2Source::Options::Check() const {
  if (device.empty()) throw InputError("--device: empty");
  if (buffers < 2 || buffers > 32) throw InputError("buffers: must be in 2..32");
  if (settle_frames < -1) throw InputError("settle frames: must be >= 0 (or -1 for automatic)");
}

V4l2Source::V4l2Source(const Options& options) : options_(options) {
  options_.Check();
  info_.path = options_.device;
  fd_ = OpenDevice(options_.device);
  if (fd_ < 0) throw InputError(options_.device + ": cannot open (" + OpenErrorText() + ")");
  try {
    FillInfo(fd_, info_);
    if (!info_.is_capture) {
      throw InputError(options_.device + ": cannot capture (" + info_.not_capture_reason + ")");
    }
    format_ = ChooseFormat(info_.formats, options_.format, options_.device);

    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    fmt.fmt.pix.width = static_cast<uint32_t>(format_.width);
    fmt.fmt.pix.height = static_cast<uint32_t>(format_.height);
    // The device's own code for the layout (JPEG and MJPG both decode as MJPEG).
    const size_t which = static_cast<size_t>(
        std::find_if(info_.formats.begin(), info_.formats.end(),
                     [&](const FormatOption& o) { return o.layout == format_.layout; }) -
        info_.formats.begin());
    fmt.fmt.pix.pixelformat = info_.fourccs.at(which);
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    Ioctl(VIDIOC_S_FMT, &fmt, "VIDIOC_S_FMT");
    // The driver may adjust what it was asked for; accept a size change, not a format change.
    const auto got = LayoutFromV4l2Fourcc(fmt.fmt.pix.pixelformat);
    if (!got || *got != format_.layout) {
      throw InputError(options_.device + ": refused format " + LayoutName(format_.layout) +
                       " (driver chose " + FourccToString(fmt.fmt.pix.pixelformat) + ")");
    }
    if (static_cast<int>(fmt.fmt.pix.width) != format_.width ||
        static_cast<int>(fmt.fmt.pix.height) != format_.height) {
      spdlog::warn("{}: asked for {}x{}, driver set {}x{}", options_.device, format_.width,
                   format_.height, fmt.fmt.pix.width, fmt.fmt.pix.height);
      format_.width = static_cast<int>(fmt.fmt.pix.width);
      format_.height = static_cast<int>(fmt.fmt.pix.height);
    }
    stride_ = fmt.fmt.pix.bytesperline;
    if (stride_ == 0) stride_ = MinStride(format_.layout, format_.width);
    spdlog::info("{}: {} {}x{}, stride {} bytes", options_.device, LayoutName(format_.layout),
                 format_.width, format_.height, stride_);

    gain_control_ = QueryControl(fd_, V4L2_CID_ANALOGUE_GAIN) ? V4L2_CID_ANALOGUE_GAIN
                    : QueryControl(fd_, V4L2_CID_GAIN)        ? V4L2_CID_GAIN
                                                              : 0;
    if (options_.longest_exposure_s > 0.0) SetFramePeriod(fmt.fmt.pix.pixelformat);
    StartStreaming();
  } catch (...) {
    StopStreaming();
    v4l2_close(fd_);
    fd_ = -1;
    throw;
  }
}

V4l2Source::~V4l2Source() {
  StopStreaming();
  if (fd_ >= 0) v4l2_close(fd_);
}

void V4l2Source::Ioctl(unsigned long request, void* arg, const char* what) const {
  if (Xioctl(fd_, request, arg) != 0) {
    throw InputError(ErrnoText(options_.device + ": " + what + " failed"));
  }
}

void V4l2Source::SetFramePeriod(uint32_t fourcc) {
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (Xioctl(fd_, VIDIOC_G_PARM, &parm) != 0 ||
      !(parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
    spdlog::info("{}: frame rate is not adjustable", options_.device);
    return;
  }
  std::vector<PeriodRange> offered;
  for (uint32_t i = 0;; ++i) {
    v4l2_frmivalenum fi{};
    fi.index = i;
    fi.pixel_format = fourcc;
    fi.width = static_cast<uint32_t>(format_.width);
    fi.height = static_cast<uint32_t>(format_.height);
    if (Xioctl(fd_, VIDIOC_ENUM_FRAMEINTERVALS, &fi) != 0) break;
    const auto seconds = [](const v4l2_fract& f) {
      return f.denominator == 0 ? 0.0 : static_cast<double>(f.numerator) / f.denominator;
    };
    if (fi.type == V4L2_FRMIVAL_TYPE_DISCRETE) {
      offered.push_back({seconds(fi.discrete), seconds(fi.discrete)});
    } else {
      offered.push_back({seconds(fi.stepwise.min), seconds(fi.stepwise.max)});
      break;
    }
  }
  const double period = ChooseFramePeriod(offered, options_.longest_exposure_s);
  if (period <= 0.0) return;
  if (period < options_.longest_exposure_s) {
    spdlog::warn(
        "{}: the slowest frame rate ({:.3g} s per frame) is shorter than the longest "
        "exposure {}; the device may clip it (see the exposures read back)",
        options_.device, period, FormatDuration(options_.longest_exposure_s));
  }
  // Microsecond resolution is finer than any driver's interval table.
  parm.parm.capture.timeperframe.numerator = static_cast<uint32_t>(std::lround(period * 1e6));
  parm.parm.capture.timeperframe.denominator = 1000000;
  if (Xioctl(fd_, VIDIOC_S_PARM, &parm) != 0) {
    spdlog::warn("{}: VIDIOC_S_PARM failed: {}", options_.device, std::strerror(errno));
    return;
  }
  const v4l2_fract& got = parm.parm.capture.timeperframe;
  spdlog::info("{}: frame period {}/{} s", options_.device, got.numerator, got.denominator);
}

void V4l2Source::StartStreaming() {
  v4l2_requestbuffers req{};
  req.count = static_cast<uint32_t>(options_.buffers);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  Ioctl(VIDIOC_REQBUFS, &req, "VIDIOC_REQBUFS (mmap streaming)");
  if (req.count < 2) throw InputError(options_.device + ": driver granted fewer than 2 buffers");
  buffers_.resize(req.count);
  for (uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    buf.index = i;
    Ioctl(VIDIOC_QUERYBUF, &buf, "VIDIOC_QUERYBUF");
    void* start =
        v4l2_mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buf.m.offset);
    if (start == MAP_FAILED) throw InputError(ErrnoText(options_.device + ": mmap failed"));
    buffers_[i] = {start, buf.length};
  }
  for (uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    buf.index = i;
    Ioctl(VIDIOC_QBUF, &buf, "VIDIOC_QBUF");
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  Ioctl(VIDIOC_STREAMON, &type, "VIDIOC_STREAMON");
  streaming_ = true;
}

void V4l2Source::StopStreaming() {
  if (fd_ < 0) return;
  if (streaming_) {
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    Xioctl(fd_, VIDIOC_STREAMOFF, &type);
    streaming_ = false;
  }
  for (const Buffer& b : buffers_) {
    if (b.start) v4l2_munmap(b.start, b.length);
  }
  if (!buffers_.empty()) {
    // Release the driver's buffers so the device can be reconfigured by the next user.
    v4l2_requestbuffers req{};
    req.count = 0;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    Xioctl(fd_, VIDIOC_REQBUFS, &req);
  }
  buffers_.clear();
}

bool V4l2Source::TrySetControl(uint32_t id, int32_t value) {
  if (!QueryControl(fd_, id)) return false;
  v4l2_control c{};
  c.id = id;
  c.value = value;
  if (Xioctl(fd_, VIDIOC_S_CTRL, &c) != 0) {
    spdlog::warn("{}: could not set control 0x{:x} to {}: {}", options_.device, id, value,
                 std::strerror(errno));
    return false;
  }
  return true;
}

int32_t V4l2Source::GetControl(uint32_t id) const {
  v4l2_control c{};
  c.id = id;
  if (Xioctl(fd_, VIDIOC_G_CTRL, &c) != 0) {
    throw InputError(
        ErrnoText(options_.device + ": reading control 0x" + fmt::format("{:x}", id) + " failed"));
  }
  return c.value;
}

std::string V4l2Source::Id() const {
  return "v4l2:" + info_.card + (info_.bus_info.empty() ? "" : "@" + info_.bus_info);
}

std::string V4l2Source::GainUnit() const { return Session::kGainDevice; }

void V4l2Source::SetExposure(double exposure_s, std::optional<double> gain) {
  if (!info_.exposure_100us) {
    throw InputError(options_.device +
                     ": has no V4L2_CID_EXPOSURE_ABSOLUTE control, so exposure cannot be set in "
                     "seconds (for sensor modules try --backend libcamera)");
  }
  if (!manual_set_) {
    // Manual exposure must be in the menu; aperture priority would still let the camera vary it.
    if (QueryControl(fd_, V4L2_CID_EXPOSURE_AUTO)) {
      if (!MenuHasItem(fd_, V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL) ||
          !TrySetControl(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL)) {
        throw InputError(options_.device + ": refuses manual exposure (V4L2_CID_EXPOSURE_AUTO)");
      }
    }
    TrySetControl(V4L2_CID_AUTOGAIN, 0);
    if (TrySetControl(V4L2_CID_AUTO_WHITE_BALANCE, 0)) {
      spdlog::info("{}: auto white balance off", options_.device);
    }
    manual_set_ = true;
  }
  const V4l2ControlRange& r = *info_.exposure_100us;
  const double units = exposure_s / kExposureUnitS;
  if (units < r.min - 0.5 || units > r.max + 0.5) {
    throw InputError(fmt::format("{}: exposure {} is outside the device range {} .. {}",
                                 options_.device, FormatDuration(exposure_s),
                                 FormatDuration(r.min * kExposureUnitS),
                                 FormatDuration(r.max * kExposureUnitS)));
  }
  const int32_t steps = static_cast<int32_t>(std::lround((units - r.min) / r.step));
  const int32_t value = std::clamp(r.min + steps * r.step, r.min, r.max);
  if (!TrySetControl(V4L2_CID_EXPOSURE_ABSOLUTE, value)) {
    throw InputError(options_.device + ": refused exposure " + FormatDuration(exposure_s));
  }
  if (gain_control_ != 0) {
    const auto g = ControlRange(fd_, gain_control_);
    if (g) {
      const double want = gain.value_or(static_cast<double>(g->min));
      if (want < g->min || want > g->max) {
        throw InputError(fmt::format("{}: gain {} is outside the device range {} .. {}",
                                     options_.device, want, g->min, g->max));
      }
      TrySetControl(gain_control_, static_cast<int32_t>(std::lround(want)));
    }
  } else if (gain) {
    throw InputError(options_.device + ": has no gain control");
  }
  const double read_back = GetControl(V4L2_CID_EXPOSURE_ABSOLUTE) * kExposureUnitS;
  if (std::abs(read_back - exposure_s) > 0.05 * exposure_s) {
    spdlog::warn("{}: asked for {}, device uses {}", options_.device, FormatDuration(exposure_s),
                 FormatDuration(read_back));
  }
  last_exposure_s_ = read_back;
  Settle();
}

void V4l2Source::Settle() {
  const int drop =
      options_.settle_frames >= 0 ? options_.settle_frames : static_cast<int>(buffers_.size()) + 2;
  for (int i = 0; i < drop; ++i) {
    if (!Grab()) break;
  }
}

std::optional<CapturedFrame> V4l2Source::Grab() {
  // Long exposures lower the frame rate; allow for a few frame times plus USB latency.
  const double timeout_s = 2.0 + 3.0 * std::max(last_exposure_s_, 0.0);
  for (int attempt = 0; attempt < 10; ++attempt) {
    pollfd p{fd_, POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(timeout_s * 1000));
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw InputError(ErrnoText(options_.device + ": poll failed"));
    if (r == 0) {
      throw InputError(fmt::format("{}: no frame within {:.1f} s", options_.device, timeout_s));
    }
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (Xioctl(fd_, VIDIOC_DQBUF, &buf) != 0) {
      if (errno == EAGAIN) continue;
      throw InputError(ErrnoText(options_.device + ": VIDIOC_DQBUF failed"));
    }
    CapturedFrame frame;
    const bool damaged =
        (buf.flags & V4L2_BUF_FLAG_ERROR) || buf.bytesused == 0 || buf.index >= buffers_.size();
    if (!damaged) {
      const Buffer& b = buffers_[buf.index];
      frame.image = ConvertFrame(format_.layout, format_.width, format_.height, stride_,
                                 static_cast<const uint8_t*>(b.start),
                                 std::min<size_t>(buf.bytesused, b.length));
      frame.timestamp_s = buf.timestamp.tv_sec + 1e-6 * buf.timestamp.tv_usec;
      frame.sequence = buf.sequence;
    }
    // Requeue at once: the image was copied out, and the ring must not run dry.
    Ioctl(VIDIOC_QBUF, &buf, "VIDIOC_QBUF");
    if (frame.image.empty()) {
      spdlog::debug("{}: dropped a damaged frame (sequence {})", options_.device, buf.sequence);
      continue;
    }
    // V4L2 has no per-frame metadata: the control values read right after the frame are the
    // ones it was taken with, because Settle() dropped every frame older than the last change.
    frame.exposure_s =
        info_.exposure_100us ? GetControl(V4L2_CID_EXPOSURE_ABSOLUTE) * kExposureUnitS : 0.0;
    frame.gain = gain_control_ != 0 ? static_cast<double>(GetControl(gain_control_)) : 1.0;
    return frame;
  }
  throw InputError(options_.device + ": 10 damaged frames in a row");
}

}  // namespace gonio::capture
