// libcamera backend (compiled only with GONIO_HAVE_LIBCAMERA). Written against libcamera
// 0.0.3's public API (/usr/include/libcamera).
#include "capture/libcamera_source.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>

#include <libcamera/libcamera.h>
#include <sys/mman.h>
#include <sys/stat.h>

#include "capture/bracket.h"
#include "common/error.h"
#include "common/log.h"
#include "common/session.h"

namespace lc = libcamera;

namespace gonio::capture {
namespace {

struct LcLayout {
  lc::PixelFormat format;
  PixelLayout layout;
};
// libcamera names formats by DRM fourcc: RGB888 is stored B, G, R in memory.
const LcLayout kLcLayouts[] = {
    {lc::formats::R8, PixelLayout::kGrey},      {lc::formats::R10, PixelLayout::kY10},
    {lc::formats::R12, PixelLayout::kY12},      {lc::formats::YUYV, PixelLayout::kYuyv},
    {lc::formats::NV12, PixelLayout::kNv12},    {lc::formats::MJPEG, PixelLayout::kMjpeg},
    {lc::formats::RGB888, PixelLayout::kBgr24}, {lc::formats::BGR888, PixelLayout::kRgb24},
};

std::optional<PixelLayout> LayoutOf(const lc::PixelFormat& f) {
  for (const auto& l : kLcLayouts) {
    if (l.format == f) return l.layout;
  }
  return std::nullopt;
}

lc::PixelFormat FormatOf(PixelLayout layout) {
  for (const auto& l : kLcLayouts) {
    if (l.layout == layout) return l.format;
  }
  return {};
}

// The formats a stream offers that gonio converts, as FormatOptions for ChooseFormat.
std::vector<FormatOption> Offered(const lc::StreamFormats& formats,
                                  std::vector<std::string>* unsupported) {
  std::vector<FormatOption> out;
  for (const lc::PixelFormat& pf : formats.pixelformats()) {
    const auto layout = LayoutOf(pf);
    if (!layout) {
      if (unsupported) unsupported->push_back(pf.toString());
      continue;
    }
    FormatOption o{*layout, {}};
    for (const lc::Size& s : formats.sizes(pf)) {
      const int w = static_cast<int>(s.width), h = static_cast<int>(s.height);
      o.sizes.push_back({w, w, 1, h, h, 1});
    }
    if (o.sizes.empty()) {
      const lc::SizeRange r = formats.range(pf);
      o.sizes.push_back({static_cast<int>(r.min.width), static_cast<int>(r.max.width),
                         static_cast<int>(std::max(1u, r.hStep)), static_cast<int>(r.min.height),
                         static_cast<int>(r.max.height), static_cast<int>(std::max(1u, r.vStep))});
    }
    out.push_back(o);
  }
  return out;
}

std::string ModelOf(const lc::Camera& camera) {
  const auto model = camera.properties().get(lc::properties::Model);
  return model ? *model : std::string();
}

// libcamera allows one CameraManager per process; start() enumerates the cameras.
std::unique_ptr<lc::CameraManager> StartManager() {
  // libcamera logs INFO lines to stderr by default; keep stderr for gonio's one-line errors
  // unless the user asked for libcamera's logs (its own LIBCAMERA_LOG_LEVELS variable).
  // libcamera reads the variable when its logger starts (category levels set later through
  // logSetLevel miss the categories created afterwards), so set it before the first use.
  ::setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", /*overwrite=*/0);
  auto manager = std::make_unique<lc::CameraManager>();
  const int r = manager->start();
  if (r != 0) {
    throw InputError(std::string("libcamera: camera manager failed to start (") +
                     std::strerror(-r) + ")");
  }
  return manager;
}

}  // namespace

bool HaveLibcamera() { return true; }

nlohmann::json ListLibcameraCameras() {
  auto manager = StartManager();
  nlohmann::json list = nlohmann::json::array();
  {
    const auto cameras = manager->cameras();
    for (size_t i = 0; i < cameras.size(); ++i) {
      const auto& camera = cameras[i];
      nlohmann::json j = {{"backend", "libcamera"},
                          {"device", std::to_string(i)},
                          {"id", camera->id()},
                          {"model", ModelOf(*camera)}};
      // Formats come from a generated configuration; that does not need the camera acquired.
      auto config = camera->generateConfiguration({lc::StreamRole::StillCapture});
      nlohmann::json fmts = nlohmann::json::array();
      std::vector<std::string> unsupported;
      if (config && !config->empty()) {
        for (const auto& o : Offered(config->at(0).formats(), &unsupported)) {
          nlohmann::json sizes = nlohmann::json::array();
          for (const auto& s : o.sizes) sizes.push_back(s.ToString());
          fmts.push_back({{"format", LayoutName(o.layout)}, {"sizes", sizes}});
        }
      }
      j["formats"] = fmts;
      j["unsupported_formats"] = unsupported;
      const auto& controls = camera->controls();
      const auto it = controls.find(&lc::controls::ExposureTime);
      if (it != controls.end()) {
        j["exposure_range_s"] = {it->second.min().get<int32_t>() * 1e-6,
                                 it->second.max().get<int32_t>() * 1e-6};
      }
      list.push_back(j);
    }
  }
  manager->stop();
  return list;
}

void LibcameraSource::Options::Check() const {
  if (buffers < 1 || buffers > 32) throw InputError("buffers: must be in 1..32");
  if (max_settle_frames < 1) throw InputError("settle frames: must be >= 1");
}

struct LibcameraSource::Impl {
  Options options;
  std::unique_ptr<lc::CameraManager> manager;
  std::shared_ptr<lc::Camera> camera;
  bool acquired = false, started = false;
  std::unique_ptr<lc::CameraConfiguration> config;
  lc::Stream* stream = nullptr;
  std::unique_ptr<lc::FrameBufferAllocator> allocator;
  std::vector<std::unique_ptr<lc::Request>> requests;
  // mmap of each dmabuf, keyed by fd: planes of one buffer often share one fd at offsets.
  struct Mapping {
    void* address = nullptr;
    size_t length = 0;
  };
  std::map<int, Mapping> mappings;
  ChosenFormat format{};
  size_t stride = 0;

  std::mutex mutex;
  std::condition_variable completed_cv;
  std::deque<lc::Request*> completed;  // filled from libcamera's thread

  // Controls to attach to the next queued request (libcamera keeps them until changed).
  lc::ControlList pending{lc::controls::controls};
  double want_exposure_s = 0.0;
  std::optional<double> want_gain;
  bool warned_no_metadata = false;

  std::string Name() const { return "libcamera:" + (camera ? camera->id() : options.camera); }

  void OnRequestCompleted(lc::Request* request) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      completed.push_back(request);
    }
    completed_cv.notify_one();
  }

  bool Supports(const lc::ControlId& id) const { return camera->controls().count(&id) > 0; }

  void Select(const std::string& which) {
    const auto cameras = manager->cameras();
    if (cameras.empty()) {
      throw InputError((which.empty() ? std::string("libcamera") : which) +
                       ": no camera found by libcamera");
    }
    if (which.empty()) {
      camera = cameras.front();
    } else if (std::all_of(which.begin(), which.end(), ::isdigit)) {
      const size_t index = std::stoul(which);
      if (index >= cameras.size()) {
        throw InputError("libcamera: camera " + which + " does not exist (" +
                         std::to_string(cameras.size()) + " cameras)");
      }
      camera = cameras[index];
    } else if (which.rfind("/dev/", 0) == 0) {
      struct stat st {};
      if (::stat(which.c_str(), &st) != 0) {
        throw InputError(which + ": cannot open (" + std::strerror(errno) + ")");
      }
      camera = manager->get(st.st_rdev);
      if (!camera) throw InputError(which + ": not a camera libcamera drives");
    } else {
      camera = manager->get(which);
      if (!camera) throw InputError("libcamera: no camera with id '" + which + "'");
    }
  }

  void Configure() {
    if (camera->acquire() != 0) throw InputError(Name() + ": busy (another program uses it)");
    acquired = true;
    // StillCapture gives processed (ISP) output on embedded pipelines; raw Bayer is not
    // converted by gonio.
    config = camera->generateConfiguration({lc::StreamRole::StillCapture});
    if (!config || config->empty()) throw InputError(Name() + ": no stream configuration");
    lc::StreamConfiguration& sc = config->at(0);
    std::vector<std::string> unsupported;
    format = ChooseFormat(Offered(sc.formats(), &unsupported), options.format, Name());
    sc.pixelFormat = FormatOf(format.layout);
    sc.size = lc::Size(static_cast<unsigned>(format.width), static_cast<unsigned>(format.height));
    sc.bufferCount = static_cast<unsigned>(options.buffers);
    const auto status = config->validate();
    if (status == lc::CameraConfiguration::Invalid) {
      throw InputError(Name() + ": configuration " + sc.toString() + " is invalid");
    }
    if (status == lc::CameraConfiguration::Adjusted) {
      spdlog::warn("{}: configuration adjusted to {}", Name(), sc.toString());
      const auto layout = LayoutOf(sc.pixelFormat);
      if (!layout) {
        throw InputError(Name() + ": adjusted to " + sc.pixelFormat.toString() +
                         ", which gonio does not convert");
      }
      format = {*layout, static_cast<int>(sc.size.width), static_cast<int>(sc.size.height)};
    }
    if (camera->configure(config.get()) != 0) {
      throw InputError(Name() + ": configure(" + sc.toString() + ") failed");
    }
    stream = sc.stream();
    stride = sc.stride != 0 ? sc.stride : MinStride(format.layout, format.width);
    spdlog::info("{}: {} {}x{}, stride {} bytes", Name(), LayoutName(format.layout), format.width,
                 format.height, stride);
  }

  void AllocateAndMap() {
    allocator = std::make_unique<lc::FrameBufferAllocator>(camera);
    if (allocator->allocate(stream) < 0) throw InputError(Name() + ": buffer allocation failed");
    for (const auto& buffer : allocator->buffers(stream)) {
      std::map<int, size_t> extent;
      for (const auto& plane : buffer->planes()) {
        const int fd = plane.fd.get();
        extent[fd] = std::max(extent[fd], static_cast<size_t>(plane.offset) + plane.length);
      }
      for (const auto& [fd, length] : extent) {
        if (mappings.count(fd)) continue;
        void* address = ::mmap(nullptr, length, PROT_READ, MAP_SHARED, fd, 0);
        if (address == MAP_FAILED) throw InputError(Name() + ": mmap of a frame buffer failed");
        mappings[fd] = {address, length};
      }
      std::unique_ptr<lc::Request> request = camera->createRequest();
      if (!request) throw InputError(Name() + ": createRequest failed");
      if (request->addBuffer(stream, buffer.get()) != 0) {
        throw InputError(Name() + ": addBuffer failed");
      }
      requests.push_back(std::move(request));
    }
  }

  void Start() {
    camera->requestCompleted.connect(this, &Impl::OnRequestCompleted);
    // Manual from the first frame: no auto exposure or auto white balance drifting between
    // the frames of a bracket.
    lc::ControlList initial(lc::controls::controls);
    if (Supports(lc::controls::AeEnable)) initial.set(lc::controls::AeEnable, false);
    if (Supports(lc::controls::AwbEnable)) initial.set(lc::controls::AwbEnable, false);
    if (camera->start(&initial) != 0) throw InputError(Name() + ": start failed");
    started = true;
    for (auto& request : requests) {
      if (camera->queueRequest(request.get()) != 0)
        throw InputError(Name() + ": queueRequest failed");
    }
  }

  void Shutdown() {
    if (started) {
      camera->stop();
      started = false;
    }
    if (camera) camera->requestCompleted.disconnect(this);
    requests.clear();
    for (const auto& [fd, m] : mappings) ::munmap(m.address, m.length);
    mappings.clear();
    if (allocator && stream) allocator->free(stream);
    allocator.reset();
    if (acquired) camera->release();
    acquired = false;
    config.reset();
    camera.reset();
    if (manager) manager->stop();
    manager.reset();
  }

  lc::Request* WaitCompleted() {
    const double timeout_s = 2.0 + 3.0 * want_exposure_s;
    std::unique_lock<std::mutex> lock(mutex);
    if (!completed_cv.wait_for(lock, std::chrono::duration<double>(timeout_s),
                               [&] { return !completed.empty(); })) {
      throw InputError(fmt::format("{}: no frame within {:.1f} s", Name(), timeout_s));
    }
    lc::Request* r = completed.front();
    completed.pop_front();
    return r;
  }

  void Requeue(lc::Request* request) {
    request->reuse(lc::Request::ReuseBuffers);
    if (!pending.empty()) {
      request->controls().merge(pending);
      pending.clear();
    }
    if (camera->queueRequest(request) != 0) throw InputError(Name() + ": queueRequest failed");
  }

  // The frame's pixels as one continuous buffer in the layout ConvertFrame expects.
  cv::Mat Convert(const lc::FrameBuffer& buffer) {
    const auto& planes = buffer.planes();
    const auto& meta = buffer.metadata().planes();
    if (planes.empty()) return {};
    const auto data = [&](size_t i) {
      const Mapping& m = mappings.at(planes[i].fd.get());
      return static_cast<const uint8_t*>(m.address) + planes[i].offset;
    };
    if (planes.size() == 1 || data(1) == data(0) + stride * static_cast<size_t>(format.height)) {
      size_t used = 0;
      for (size_t i = 0; i < planes.size(); ++i) {
        used += i < meta.size() ? meta[i].bytesused : planes[i].length;
      }
      return ConvertFrame(format.layout, format.width, format.height, stride, data(0), used);
    }
    // Planes in separate buffers (NV12 on some ISPs): join them.
    std::vector<uint8_t> joined;
    for (size_t i = 0; i < planes.size(); ++i) {
      const size_t used = i < meta.size() ? meta[i].bytesused : planes[i].length;
      joined.insert(joined.end(), data(i), data(i) + used);
    }
    return ConvertFrame(format.layout, format.width, format.height, stride, joined.data(),
                        joined.size());
  }
};

LibcameraSource::LibcameraSource(const Options& options) : impl_(std::make_unique<Impl>()) {
  options.Check();
  impl_->options = options;
  try {
    impl_->manager = StartManager();
    impl_->Select(options.camera);
    impl_->Configure();
    impl_->AllocateAndMap();
    impl_->Start();
  } catch (...) {
    impl_->Shutdown();
    throw;
  }
}

LibcameraSource::~LibcameraSource() { impl_->Shutdown(); }

std::string LibcameraSource::Id() const {
  const std::string model = ModelOf(*impl_->camera);
  return "libcamera:" + (model.empty() ? impl_->camera->id() : model + "@" + impl_->camera->id());
}

std::string LibcameraSource::GainUnit() const { return Session::kGainAnalogue; }

void LibcameraSource::SetExposure(double exposure_s, std::optional<double> gain) {
  Impl& d = *impl_;
  const auto& controls = d.camera->controls();
  const auto exposure = controls.find(&lc::controls::ExposureTime);
  if (exposure == controls.end()) {
    throw InputError(d.Name() + ": has no ExposureTime control");
  }
  const double lo = exposure->second.min().get<int32_t>() * 1e-6;
  const double hi = exposure->second.max().get<int32_t>() * 1e-6;
  if (exposure_s < lo || exposure_s > hi) {
    throw InputError(fmt::format("{}: exposure {} is outside the camera range {} .. {}", d.Name(),
                                 FormatDuration(exposure_s), FormatDuration(lo),
                                 FormatDuration(hi)));
  }
  const auto exposure_us = static_cast<int32_t>(std::lround(exposure_s * 1e6));
  d.pending.set(lc::controls::ExposureTime, exposure_us);
  // The sensor cannot expose longer than a frame: widen the frame-duration limit to fit.
  const auto fd = controls.find(&lc::controls::FrameDurationLimits);
  if (fd != controls.end()) {
    const int64_t fd_min = fd->second.min().get<int64_t>();
    const int64_t fd_max = fd->second.max().get<int64_t>();
    const int64_t need = std::clamp<int64_t>(exposure_us + 2000, fd_min, fd_max);
    d.pending.set(lc::controls::FrameDurationLimits, {fd_min, std::max(fd_min, need)});
  }
  const auto gain_info = controls.find(&lc::controls::AnalogueGain);
  if (gain_info != controls.end()) {
    const float glo = gain_info->second.min().get<float>();
    const float ghi = gain_info->second.max().get<float>();
    const double want = gain.value_or(std::max(1.0f, glo));
    if (want < glo || want > ghi) {
      throw InputError(fmt::format("{}: gain {} is outside the camera range {} .. {}", d.Name(),
                                   want, glo, ghi));
    }
    d.pending.set(lc::controls::AnalogueGain, static_cast<float>(want));
    d.want_gain = want;
  } else if (gain) {
    throw InputError(d.Name() + ": has no AnalogueGain control");
  } else {
    d.want_gain.reset();
  }
  d.want_exposure_s = exposure_s;
  Settle();
}

void LibcameraSource::Settle() {
  Impl& d = *impl_;
  // Per-frame metadata says what the sensor used, so wait until it reports the request (the
  // sensor rounds exposure to whole lines, hence the tolerance) and drop everything before.
  std::deque<lc::Request*> drained;
  {
    std::lock_guard<std::mutex> lock(d.mutex);
    drained.swap(d.completed);
  }
  for (lc::Request* r : drained) d.Requeue(r);
  if (d.want_exposure_s <= 0.0) return;
  for (int i = 0; i < d.options.max_settle_frames; ++i) {
    lc::Request* r = d.WaitCompleted();
    if (r->status() == lc::Request::RequestComplete) {
      const auto exposure_us = r->metadata().get(lc::controls::ExposureTime);
      const auto gain = r->metadata().get(lc::controls::AnalogueGain);
      // Without metadata there is nothing to wait for; Grab warns and records the request.
      const bool exposure_ok = !exposure_us || std::abs(*exposure_us * 1e-6 - d.want_exposure_s) <=
                                                   std::max(0.03 * d.want_exposure_s, 100e-6);
      const bool gain_ok =
          !d.want_gain || !gain || std::abs(*gain - *d.want_gain) <= 0.05 * *d.want_gain;
      if (exposure_ok && gain_ok) {
        std::lock_guard<std::mutex> lock(d.mutex);
        d.completed.push_front(r);  // the first good frame is the next Grab's
        return;
      }
    }
    d.Requeue(r);
  }
  throw InputError(fmt::format("{}: exposure {} not reached after {} frames", d.Name(),
                               FormatDuration(d.want_exposure_s), d.options.max_settle_frames));
}

std::optional<CapturedFrame> LibcameraSource::Grab() {
  Impl& d = *impl_;
  for (int attempt = 0; attempt < 10; ++attempt) {
    lc::Request* r = d.WaitCompleted();
    if (r->status() != lc::Request::RequestComplete) {
      d.Requeue(r);
      continue;
    }
    const lc::FrameBuffer* buffer = r->findBuffer(d.stream);
    CapturedFrame frame;
    if (buffer && buffer->metadata().status == lc::FrameMetadata::FrameSuccess) {
      frame.image = d.Convert(*buffer);
      frame.sequence = buffer->metadata().sequence;
      frame.timestamp_s = buffer->metadata().timestamp * 1e-9;
    }
    const auto exposure_us = r->metadata().get(lc::controls::ExposureTime);
    const auto gain = r->metadata().get(lc::controls::AnalogueGain);
    const auto sensor_ts = r->metadata().get(lc::controls::SensorTimestamp);
    if (sensor_ts) frame.timestamp_s = *sensor_ts * 1e-9;
    if (exposure_us) {
      frame.exposure_s = *exposure_us * 1e-6;
    } else {
      if (!d.warned_no_metadata) {
        spdlog::warn("{}: frames carry no ExposureTime metadata; recording the requested value",
                     d.Name());
        d.warned_no_metadata = true;
      }
      frame.exposure_s = d.want_exposure_s;
    }
    frame.gain = gain ? static_cast<double>(*gain) : d.want_gain.value_or(1.0);
    d.Requeue(r);
    if (frame.image.empty()) continue;
    return frame;
  }
  throw InputError(d.Name() + ": 10 damaged frames in a row");
}

}  // namespace gonio::capture
