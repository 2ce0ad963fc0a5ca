#include "common/session.h"

#include <fstream>

#include <gtest/gtest.h>

#include "common/error.h"
#include "common/io.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

void Touch(const fs::path& p) { std::ofstream(p) << "x"; }

Session TwoFrameSession(const fs::path& dir) {
  Touch(dir / "frame_0000.png");
  Touch(dir / "frame_0001.png");
  Touch(dir / "board.json");
  Session s;
  s.camera_id = "v4l2:/dev/video0:Test Cam";
  s.board = "board.json";
  s.gain_unit = Session::kGainDevice;
  s.frames = {{"frame_0000.png", 0.001, 0.0, 0.0, 0, ""},
              {"frame_0001.png", 0.004, 12.0, 0.25, 0, ""}};
  return s;
}

// Expects ReadSession to throw an InputError whose message names `file` and contains `problem`.
void ExpectReadError(const fs::path& file, const std::string& problem) {
  try {
    ReadSession(file.parent_path());
    FAIL() << "no error for " << problem;
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(file.string()), std::string::npos) << msg;
    EXPECT_NE(msg.find(problem), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

TEST(Session, RoundTripKeepsEveryField) {
  testing::TempDir dir;
  const Session written = TwoFrameSession(dir.path());
  WriteSession(dir.path(), written);
  const Session read = ReadSession(dir.path());
  EXPECT_EQ(read.camera_id, written.camera_id);
  EXPECT_EQ(read.board, "board.json");
  EXPECT_EQ(read.gain_unit, "device");
  ASSERT_EQ(read.frames.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(read.frames[i].file, written.frames[i].file);
    EXPECT_DOUBLE_EQ(read.frames[i].exposure_s, written.frames[i].exposure_s);
    EXPECT_DOUBLE_EQ(read.frames[i].gain, written.frames[i].gain);
    EXPECT_DOUBLE_EQ(read.frames[i].timestamp, written.frames[i].timestamp);
    EXPECT_EQ(read.frames[i].bracket, written.frames[i].bracket);
  }
  EXPECT_EQ(read.FramePath(1), dir.path() / "frame_0001.png");
  EXPECT_EQ(read.BoardPath(), dir.path() / "board.json");
  // Provenance is there, as for every JSON output.
  EXPECT_EQ(ReadJsonFile(dir.path() / "session.json")["provenance"]["tool"], "gonio");
}

// bit_depth (docs/formats.md, written by gonio synth) is optional, kept, and checked.
TEST(Session, BitDepthRoundTripsAndIsChecked) {
  testing::TempDir dir;
  Session s = TwoFrameSession(dir.path());
  EXPECT_EQ(s.bit_depth, 0);
  s.bit_depth = 12;
  WriteSession(dir.path(), s);
  EXPECT_EQ(ReadSession(dir.path()).bit_depth, 12);
  s.bit_depth = 7;
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);
  std::ofstream(dir.path() / "session.json")
      << R"({"format": "gonio-session", "version": 1, "bit_depth": 20,
             "frames": [{"file": "frame_0000.png", "exposure_s": 0.01}]})";
  ExpectReadError(dir.path() / "session.json", "bit_depth must be 8..16");
}

TEST(Session, ReadsTheDocumentedExampleWithDefaults) {
  testing::TempDir dir;
  Touch(dir.path() / "frame_0000.png");
  std::ofstream(dir.path() / "session.json")
      << R"({"format": "gonio-session", "version": 1, "camera_id": "synthetic",
             "frames": [{"file": "frame_0000.png", "exposure_s": 0.01}]})";
  const Session s = ReadSession(dir.path() / "session.json");
  EXPECT_EQ(s.gain_unit, "analogue");
  EXPECT_TRUE(s.board.empty());
  EXPECT_DOUBLE_EQ(s.frames[0].gain, 1.0);
  EXPECT_EQ(s.frames[0].bracket, 0);
}

TEST(Session, FailedWriteKeepsThePreviousFile) {
  testing::TempDir dir;
  Session s = TwoFrameSession(dir.path());
  WriteSession(dir.path(), s);
  const std::string before = ReadTextFile(dir.path() / "session.json");
  // A frame that is not in the folder: the write must fail and leave the old file untouched,
  // with no temporary left behind.
  s.frames.push_back({"frame_0002.png", 0.016, 1.0, 0.5, 0, ""});
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);
  EXPECT_EQ(ReadTextFile(dir.path() / "session.json"), before);
  size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) {
    (void)e;
    ++files;
  }
  EXPECT_EQ(files, 4u);  // two frames, board, session.json
}

TEST(Session, RejectsInvalidValuesBeforeWriting) {
  testing::TempDir dir;
  Session s = TwoFrameSession(dir.path());
  s.frames[0].exposure_s = 0.0;
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);
  s = TwoFrameSession(dir.path());
  s.gain_unit = Session::kGainAnalogue;  // gain 0 is only valid in device units
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);
  s = TwoFrameSession(dir.path());
  s.frames[1].file = "../escape.png";
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);
  s = TwoFrameSession(dir.path());
  s.frames[1].file = s.frames[0].file;
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);
  EXPECT_FALSE(fs::exists(dir.path() / "session.json"));
}

TEST(Session, BadFilesNameTheFileAndTheProblem) {
  testing::TempDir dir;
  const fs::path file = dir.path() / "session.json";
  Touch(dir.path() / "frame_0000.png");
  const std::string ok_frame = R"({"file": "frame_0000.png", "exposure_s": 0.01})";
  const auto write = [&](const std::string& text) { std::ofstream(file) << text; };

  write("{not json");
  ExpectReadError(file, "not valid JSON");
  write(R"({"format": "other", "version": 1, "frames": [)" + ok_frame + "]}");
  ExpectReadError(file, "format");
  write(R"({"format": "gonio-session", "version": 7, "frames": [)" + ok_frame + "]}");
  ExpectReadError(file, "version 7");
  write(R"({"format": "gonio-session", "version": 1, "fps": 3, "frames": [)" + ok_frame + "]}");
  ExpectReadError(file, "unknown key 'fps'");
  write(R"({"format": "gonio-session", "version": 1, "frames": []})");
  ExpectReadError(file, "no frames");
  write(R"({"format": "gonio-session", "version": 1, "frames": [{"file": "frame_0000.png"}]})");
  ExpectReadError(file, "missing key 'exposure_s'");
  write(R"({"format": "gonio-session", "version": 1,
            "frames": [{"file": "frame_0000.png", "exposure_s": "fast"}]})");
  ExpectReadError(file, "wrong type");
  write(R"({"format": "gonio-session", "version": 1,
            "frames": [{"file": "frame_0000.png", "exposure_s": -1}]})");
  ExpectReadError(file, "exposure_s");
  write(R"({"format": "gonio-session", "version": 1,
            "frames": [{"file": "missing.png", "exposure_s": 0.01}]})");
  ExpectReadError(file, "missing.png does not exist");
  write(R"({"format": "gonio-session", "version": 1, "board": "board.json",
            "frames": [)" +
        ok_frame + "]}");
  ExpectReadError(file, "board.json does not exist");
  fs::remove(file);
  ExpectReadError(file, "no such file");
}

// lamp_off pairs a frame with a lamp-off frame of the same pose and exposure: kept through a
// round trip, resolved against the folder, and never a frame of its own or paired twice.
TEST(Session, LampOffPairingRoundTripsAndIsChecked) {
  testing::TempDir dir;
  Session s = TwoFrameSession(dir.path());
  Touch(dir.path() / "frame_0000_off.png");
  s.frames[0].lamp_off = "frame_0000_off.png";
  WriteSession(dir.path(), s);
  const Session read = ReadSession(dir.path());
  EXPECT_EQ(read.frames[0].lamp_off, "frame_0000_off.png");
  EXPECT_EQ(read.LampOffPath(0), dir.path() / "frame_0000_off.png");
  EXPECT_TRUE(read.frames[1].lamp_off.empty());
  EXPECT_TRUE(read.LampOffPath(1).empty());

  s.frames[1].lamp_off = "frame_0000_off.png";
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);  // paired twice
  s.frames[1].lamp_off = "frame_0000.png";
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);  // a frame of its own
  s.frames[1].lamp_off = "../off.png";
  EXPECT_THROW(WriteSession(dir.path(), s), InputError);  // outside the folder
  const fs::path file = dir.path() / "session.json";
  std::ofstream(file) << R"({"format": "gonio-session", "version": 1, "frames": [
      {"file": "frame_0000.png", "exposure_s": 0.01, "lamp_off": "gone.png"}]})";
  ExpectReadError(file, "lamp-off file gone.png does not exist");
  std::ofstream(file) << R"({"format": "gonio-session", "version": 1, "frames": [
      {"file": "frame_0000.png", "exposure_s": 0.01, "lamp_off": "frame_0001.png"},
      {"file": "frame_0001.png", "exposure_s": 0.01}]})";
  ExpectReadError(file, "also listed as a frame");
}

}  // namespace
}  // namespace gonio
