// Writes a session folder frame by frame (docs/formats.md), and the loops that fill it from a
// FrameSource: exposure brackets from a camera, or every frame of a folder or video.
#pragma once

#include <filesystem>
#include <functional>
#include <istream>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "capture/frame_source.h"
#include "common/io.h"
#include "common/session.h"

namespace gonio::capture {

// Each frame is written as frame_NNNN.png (8 or 16 bit, lossless) and session.json is
// rewritten after every frame, into a temporary sibling of the session folder that Commit
// renames into place (common/io.h FolderTransaction): a capture that fails or is interrupted
// leaves nothing, not a session of some of the frames.
class SessionWriter {
 public:
  // InputError before any work when `dir` exists and is not an empty folder (never overwrite
  // a capture, nor mix a session into other files). `board` (optional) must be a JSON object
  // and is copied in as board.json.
  SessionWriter(std::filesystem::path dir, std::string camera_id, std::string gain_unit,
                const std::filesystem::path& board = {});

  // Significant bits of the frames (Session::bit_depth); call before the first Add.
  void SetBitDepth(int bits) { session_.bit_depth = bits; }
  void Add(const cv::Mat& image, double exposure_s, double gain, double timestamp_s, int bracket);
  // Puts the session folder in place; nothing is written to `dir` before.
  void Commit();
  const Session& session() const { return session_; }
  // The session folder (where it is once committed).
  const std::filesystem::path& dir() const { return dir_; }
  // Where the files are until Commit: other files of the session (a RAW import's
  // photometric.json) go here.
  const std::filesystem::path& work_dir() const { return folder_.tmp(); }

 private:
  std::filesystem::path dir_;
  FolderTransaction folder_;
  Session session_;
};

struct BracketOptions {
  std::vector<double> exposures_s;  // one frame per exposure per bracket
  int brackets = 1;
  std::optional<double> gain;  // unset: the source's lowest gain
  void Check() const;
};

// Called before each bracket with its index; return false to stop (interactive capture waits
// for the user here). Not called at all when empty.
using BeforeBracket = std::function<bool(int bracket)>;

// The interactive wait without a display: before each bracket, a prompt on `prompt` and one
// line from `in`; an empty line (ENTER) captures, "q" or the end of input stops.
BeforeBracket PromptBeforeBracket(std::istream& in, std::ostream& prompt, int brackets);

// Takes the brackets of ScheduleBrackets with a source that controls exposure. Each frame is
// recorded with the exposure and gain the source reports for it, not the requested ones.
// Timestamps are the device's, relative to the first frame. Returns the number of frames.
size_t CaptureBrackets(FrameSource& source, const BracketOptions& options, SessionWriter& writer,
                       const BeforeBracket& before_bracket = {});

// Writes every frame of a source whose exposures are fixed (folder, video): frame k goes to
// bracket k / bracket_size (bracket_size 0: all frames one pose). max_frames 0: no limit.
size_t CopyFrames(FrameSource& source, SessionWriter& writer, int bracket_size,
                  size_t max_frames = 0);

}  // namespace gonio::capture
