// The one loop over a session's frames (docs/pipeline.md "Frames"). Every stage, bench and
// command that reads a session's frames goes through SessionFrames: each frame is decoded by
// ReadImage (common/image_io.h) against one expectation, progress is reported the same way, a
// frame's lamp-off partner is read beside it, and a frame decoded for one pass (detection) can
// be kept for the next (extraction), so a run decodes each frame once within a memory budget.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <string_view>

#include <opencv2/core.hpp>

#include "common/image_io.h"
#include "common/session.h"

namespace gonio {

class SessionFrames {
 public:
  // Called with the frame's index in session.frames and its decoded image.
  using Visit = std::function<void(size_t i, const cv::Mat& image)>;
  // Which frames a pass decodes and visits; an empty filter visits every frame.
  using Filter = std::function<bool(size_t i)>;
  // After a pass visits a frame: release it, or keep it for a later pass (within the budget).
  enum class After { kRelease, kKeep };

  // `session` must outlive this object. keep_budget_mb bounds the decoded frames kept by
  // kKeep passes (0: none are kept and every pass decodes again).
  SessionFrames(const Session& session, const ImageExpectation& expect, size_t keep_budget_mb = 0);

  // Calls visit(i, image) for every frame i in order that `wanted` accepts, under one progress
  // line named `stage` (a step per frame, visited or not). A frame kept by an earlier pass is
  // handed over instead of decoded again; kept frames are released by a kRelease pass whether
  // visited or not. InputError from ReadImage names the file.
  void ForEach(std::string_view stage, const Visit& visit, const Filter& wanted = {},
               After after = After::kRelease);

  // Frame i decoded (or handed over, and released, if an earlier pass kept it): for a reader
  // that visits frames in its own order (HDR brackets).
  cv::Mat Read(size_t i);

  // Frame i's lamp-off partner (SessionFrame::lamp_off) decoded with the frames' expectation;
  // empty when the frame has none. Never kept: it is read where it is used.
  cv::Mat LampOff(size_t i) const;

  const Session& session() const { return session_; }
  const ImageExpectation& expectation() const { return expect_; }
  size_t size() const { return session_.frames.size(); }

 private:
  void Keep(size_t i, const cv::Mat& image);

  const Session& session_;
  const ImageExpectation expect_;
  size_t budget_bytes_, used_bytes_ = 0;
  std::map<size_t, cv::Mat> kept_;
};

}  // namespace gonio
