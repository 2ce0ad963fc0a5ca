// A capture session folder (docs/formats.md "Session folder"): session.json plus the frame
// images it lists. Every tool that reads or writes sessions goes through these functions so the
// format is checked in one place.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace gonio {

struct SessionFrame {
  std::string file;         // relative to the session folder
  double exposure_s = 0.0;  // > 0, as read back from the device
  double gain = 1.0;        // unit given by Session::gain_unit
  double timestamp = 0.0;   // seconds since the session started
  int bracket = 0;          // frames with equal bracket share a pose
  // A frame of the same pose, exposure and gain with the lamp off (the room's light only),
  // relative to the session folder; empty: none. Extraction subtracts its radiance
  // (docs/formats.md "Session folder", docs/pipeline.md "Ambient light").
  std::string lamp_off;
};

struct Session {
  // Meaning of SessionFrame::gain. "analogue": 1 = unity (the default when the key is absent);
  // "device": the driver's own gain control units (V4L2), comparable only within one device;
  // "iso100": ISO speed / 100 (photos imported with EXIF).
  static constexpr const char* kGainAnalogue = "analogue";
  static constexpr const char* kGainDevice = "device";
  static constexpr const char* kGainIso100 = "iso100";

  std::string camera_id;
  std::string board;  // board file relative to the folder; empty when the session has none
  std::string gain_unit = kGainAnalogue;
  int bit_depth = 0;  // significant bits of the pixel values (docs/formats.md); 0: not given
  // The camera's black level in pixel values, as the RAW converter or the camera states it;
  // < 0: not given.
  double black_level = -1;
  // Frames taken with the lens capped at the frames' settings, relative to the session folder:
  // they show the black level (docs/formats.md, docs/capture.md "Dark frames"). Not frames of
  // their own.
  std::vector<std::string> dark_frames;
  std::vector<SessionFrame> frames;

  // Folder the session was read from (set by ReadSession); the paths below resolve against it.
  std::filesystem::path dir;
  std::filesystem::path FramePath(size_t i) const { return dir / frames.at(i).file; }
  // Empty when frame i has no lamp-off frame.
  std::filesystem::path LampOffPath(size_t i) const {
    return frames.at(i).lamp_off.empty() ? std::filesystem::path() : dir / frames.at(i).lamp_off;
  }
  std::filesystem::path DarkFramePath(size_t i) const { return dir / dark_frames.at(i); }
  std::filesystem::path BoardPath() const {
    return board.empty() ? std::filesystem::path() : dir / board;
  }

  // Throws InputError("<what>: ...") on an invalid value; does not touch the disk.
  void Check(const std::string& what) const;
};

// Reads DIR/session.json (or the session.json given directly) and checks that every listed
// file exists. InputError naming the file and the problem otherwise.
Session ReadSession(const std::filesystem::path& dir_or_file);

// Writes DIR/session.json atomically (with provenance). The frame images and the board file
// must already be in DIR, so a session on disk never lists a file that is not there.
void WriteSession(const std::filesystem::path& dir, const Session& session);

}  // namespace gonio
