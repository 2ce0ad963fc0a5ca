#include "capture/session_writer.h"

#include <cctype>
#include <chrono>
#include <string>

#include <fmt/format.h>

#include "capture/bracket.h"
#include "common/error.h"
#include "common/image_io.h"
#include "common/io.h"
#include "common/log.h"

namespace fs = std::filesystem;

namespace gonio::capture {

namespace {

// Before the temporary folder exists: a capture over a session, or into a folder of other
// files, is refused with words that say so.
const fs::path& CheckedTarget(const fs::path& dir) {
  if (fs::exists(dir / "session.json")) {
    throw InputError(dir.string() + ": already holds a session (choose another --out)");
  }
  FolderTransaction::CheckTarget(dir, "");
  return dir;
}

}  // namespace

SessionWriter::SessionWriter(fs::path dir, std::string camera_id, std::string gain_unit,
                             const fs::path& board)
    : dir_(std::move(dir)), folder_(CheckedTarget(dir_), "") {
  session_.camera_id = std::move(camera_id);
  session_.gain_unit = std::move(gain_unit);
  session_.dir = folder_.tmp();
  if (!board.empty()) {
    const nlohmann::json j = ReadJsonFile(board);
    if (!j.is_object() || !j.contains("type")) {
      throw InputError(board.string() + ": not a board file (a JSON object with a 'type')");
    }
    WriteTextAtomically(folder_.tmp() / "board.json", ReadTextFile(board));
    session_.board = "board.json";
  }
}

void SessionWriter::Commit() {
  folder_.Commit();
  session_.dir = dir_;
}

void SessionWriter::Add(const cv::Mat& image, double exposure_s, double gain, double timestamp_s,
                        int bracket) {
  if (image.empty()) throw InputError(dir_.string() + ": empty frame");
  if (image.depth() != CV_8U && image.depth() != CV_16U) {
    throw InputError(dir_.string() + ": frames must be 8- or 16-bit");
  }
  const std::string file = fmt::format("frame_{:04d}.png", session_.frames.size());
  const fs::path& work = folder_.tmp();
  WriteImage(work / file, image);
  session_.frames.push_back({file, exposure_s, gain, timestamp_s, bracket, ""});  // lamp on
  try {
    WriteSession(work, session_);
  } catch (...) {
    // Keep the folder consistent with session.json: the frame it rejected goes.
    session_.frames.pop_back();
    std::error_code ec;
    fs::remove(work / file, ec);
    throw;
  }
}

void BracketOptions::Check() const {
  ScheduleBrackets(exposures_s, brackets);  // throws on an empty list, bad values, brackets < 1
  if (gain && !(std::isfinite(*gain) && *gain >= 0.0)) throw InputError("--gain: must be >= 0");
}

BeforeBracket PromptBeforeBracket(std::istream& in, std::ostream& prompt, int brackets) {
  return [&in, &prompt, brackets](int bracket) {
    prompt << "bracket " << bracket + 1 << "/" << brackets
           << ": place the board, then press Enter to capture (q + Enter stops)" << std::endl;
    std::string line;
    if (!std::getline(in, line)) return false;
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    return !(line == "q" || line == "Q");
  };
}

size_t CaptureBrackets(FrameSource& source, const BracketOptions& options, SessionWriter& writer,
                       const BeforeBracket& before_bracket) {
  options.Check();
  if (!source.ControlsExposure()) {
    throw InputError(source.Id() + ": cannot set exposures; brackets need a camera");
  }
  const std::vector<Shot> shots = ScheduleBrackets(options.exposures_s, options.brackets);
  Progress progress("capture", shots.size());
  std::optional<double> t0;
  const auto wall_start = std::chrono::steady_clock::now();
  size_t written = 0;
  int current_bracket = -1;
  for (const Shot& shot : shots) {
    if (shot.bracket != current_bracket) {
      current_bracket = shot.bracket;
      if (before_bracket) {
        if (!before_bracket(shot.bracket)) break;
        // The user took time to move the board: the frames in the driver's queue are stale.
        source.SetExposure(shot.exposure_s, options.gain);
      } else if (shot.exposure_changes) {
        source.SetExposure(shot.exposure_s, options.gain);
      }
    } else if (shot.exposure_changes) {
      source.SetExposure(shot.exposure_s, options.gain);
    }
    std::optional<CapturedFrame> frame = source.Grab();
    if (!frame) throw InputError(source.Id() + ": stopped delivering frames");
    double t = frame->timestamp_s;
    if (!(t > 0.0)) {
      // No device clock: the host's.
      t = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    }
    if (!t0) t0 = t;
    writer.Add(frame->image, frame->exposure_s, frame->gain, std::max(0.0, t - *t0), shot.bracket);
    spdlog::debug("bracket {}: asked {}, got {} gain {}", shot.bracket,
                  FormatDuration(shot.exposure_s), FormatDuration(frame->exposure_s), frame->gain);
    ++written;
    progress.Step();
  }
  progress.Done();
  return written;
}

size_t CopyFrames(FrameSource& source, SessionWriter& writer, int bracket_size, size_t max_frames) {
  if (bracket_size < 0) throw InputError("--bracket-size: must be >= 0");
  size_t k = 0;
  std::optional<double> t0;
  // Progress only when the count is known (folders); a video's frame count is a guess.
  std::optional<Progress> progress;
  if (max_frames > 0) progress.emplace("import", max_frames);
  while (max_frames == 0 || k < max_frames) {
    std::optional<CapturedFrame> frame = source.Grab();
    if (!frame) break;
    if (!t0) t0 = frame->timestamp_s;
    const int bracket = bracket_size == 0 ? 0 : static_cast<int>(k / bracket_size);
    writer.Add(frame->image, frame->exposure_s, frame->gain, frame->timestamp_s - *t0, bracket);
    ++k;
    if (progress) progress->Step();
  }
  if (progress) progress->Done();
  if (k == 0) throw InputError(source.Id() + ": no frames");
  return k;
}

}  // namespace gonio::capture
