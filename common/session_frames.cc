#include "common/session_frames.h"

#include <string>

#include "common/log.h"

namespace gonio {

SessionFrames::SessionFrames(const Session& session, const ImageExpectation& expect,
                             size_t keep_budget_mb)
    : session_(session), expect_(expect), budget_bytes_(keep_budget_mb << 20) {}

void SessionFrames::ForEach(std::string_view stage, const Visit& visit, const Filter& wanted,
                            After after) {
  Progress progress(std::string(stage), size());
  for (size_t i = 0; i < size(); ++i) {
    if (!wanted || wanted(i)) {
      const cv::Mat image = Read(i);
      visit(i, image);
      if (after == After::kKeep) Keep(i, image);
    } else if (after == After::kRelease) {
      auto it = kept_.find(i);
      if (it != kept_.end()) {
        used_bytes_ -= it->second.total() * it->second.elemSize();
        kept_.erase(it);
      }
    }
    progress.Step();
  }
  progress.Done();
}

cv::Mat SessionFrames::LampOff(size_t i) const {
  if (session_.frames.at(i).lamp_off.empty()) return cv::Mat();
  return ReadImage(session_.LampOffPath(i), expect_);
}

cv::Mat SessionFrames::Read(size_t i) {
  auto it = kept_.find(i);
  if (it == kept_.end()) return ReadImage(session_.FramePath(i), expect_);
  cv::Mat image = it->second;
  used_bytes_ -= image.total() * image.elemSize();
  kept_.erase(it);
  return image;
}

void SessionFrames::Keep(size_t i, const cv::Mat& image) {
  const size_t bytes = image.total() * image.elemSize();
  if (used_bytes_ + bytes > budget_bytes_) return;
  used_bytes_ += bytes;
  kept_[i] = image;
}

}  // namespace gonio
