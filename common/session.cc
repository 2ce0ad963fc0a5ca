#include "common/session.h"

#include <cmath>
#include <set>

#include <nlohmann/json.hpp>

#include "common/error.h"
#include "common/io.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

constexpr const char* kFormat = "gonio-session";
constexpr int kVersion = 1;

bool IsKnownGainUnit(const std::string& unit) {
  return unit == Session::kGainAnalogue || unit == Session::kGainDevice ||
         unit == Session::kGainIso100;
}

// A relative path that stays inside the session folder, so a session can be moved as a whole.
void CheckRelative(const std::string& what, const std::string& key, const std::string& file) {
  const fs::path p(file);
  if (file.empty()) throw InputError(what + ": " + key + " is empty");
  if (p.is_absolute()) throw InputError(what + ": " + key + " '" + file + "' must be relative");
  for (const auto& part : p) {
    if (part == "..") {
      throw InputError(what + ": " + key + " '" + file + "' leaves the session folder");
    }
  }
}

void RejectUnknownKeys(const std::string& what, const nlohmann::json& j,
                       const std::set<std::string>& known) {
  for (const auto& [key, value] : j.items()) {
    if (!known.count(key)) throw InputError(what + ": unknown key '" + key + "'");
  }
}

template <typename T>
T Get(const std::string& what, const nlohmann::json& j, const std::string& key) {
  if (!j.contains(key)) throw InputError(what + ": missing key '" + key + "'");
  try {
    return j.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(what + ": key '" + key + "' has the wrong type");
  }
}

}  // namespace

void Session::Check(const std::string& what) const {
  if (!IsKnownGainUnit(gain_unit)) {
    throw InputError(what + ": gain_unit '" + gain_unit +
                     "' is not one of analogue, device, iso100");
  }
  if (!board.empty()) CheckRelative(what, "board", board);
  if (bit_depth != 0 && (bit_depth < 8 || bit_depth > 16)) {
    throw InputError(what + ": bit_depth must be 8..16");
  }
  if (black_level >= 0 && !(std::isfinite(black_level) &&
                            (bit_depth == 0 || black_level < std::ldexp(1.0, bit_depth) - 1))) {
    throw InputError(what + ": black_level must be below the largest value of bit_depth");
  }
  if (frames.empty()) throw InputError(what + ": the session has no frames");
  std::set<std::string> seen;
  for (size_t i = 0; i < frames.size(); ++i) {
    const SessionFrame& f = frames[i];
    const std::string fw = what + ": frame " + std::to_string(i);
    CheckRelative(fw, "file", f.file);
    if (!seen.insert(f.file).second)
      throw InputError(fw + ": file '" + f.file + "' is listed twice");
    if (!std::isfinite(f.exposure_s) || f.exposure_s <= 0.0) {
      throw InputError(fw + ": exposure_s must be a positive number of seconds");
    }
    // Device gain controls may start at 0; analogue and ISO gains are ratios and must be > 0.
    const bool gain_ok =
        std::isfinite(f.gain) && (gain_unit == kGainDevice ? f.gain >= 0.0 : f.gain > 0.0);
    if (!gain_ok) throw InputError(fw + ": gain " + std::to_string(f.gain) + " is not valid");
    if (!std::isfinite(f.timestamp)) throw InputError(fw + ": timestamp is not finite");
    if (f.bracket < 0) throw InputError(fw + ": bracket must be >= 0");
  }
  // A lamp-off frame is not a frame of its own (no board detection, no observations): it may
  // not be listed as one, nor paired with two frames.
  std::set<std::string> lamp_off_seen;
  for (size_t i = 0; i < frames.size(); ++i) {
    const std::string& off = frames[i].lamp_off;
    if (off.empty()) continue;
    const std::string fw = what + ": frame " + std::to_string(i);
    CheckRelative(fw, "lamp_off", off);
    if (seen.count(off)) {
      throw InputError(fw + ": lamp_off '" + off + "' is also listed as a frame");
    }
    if (!lamp_off_seen.insert(off).second) {
      throw InputError(fw + ": lamp_off '" + off + "' is paired with two frames");
    }
  }
  // A dark frame is not a frame either: listed once, neither as a frame nor as a lamp-off frame.
  std::set<std::string> dark_seen;
  for (const std::string& dark : dark_frames) {
    CheckRelative(what, "dark_frames", dark);
    if (seen.count(dark) || lamp_off_seen.count(dark) || !dark_seen.insert(dark).second) {
      throw InputError(what + ": dark frame '" + dark + "' is listed twice");
    }
  }
}

Session ReadSession(const fs::path& dir_or_file) {
  const fs::path file = fs::is_directory(dir_or_file) ? dir_or_file / "session.json" : dir_or_file;
  const std::string what = file.string();
  const nlohmann::json j = ReadJsonFile(file);
  if (!j.is_object()) throw InputError(what + ": not a JSON object");
  RejectUnknownKeys(what, j,
                    {"format", "version", "camera_id", "board", "gain_unit", "bit_depth",
                     "black_level", "dark_frames", "frames", "provenance"});
  if (Get<std::string>(what, j, "format") != kFormat) {
    throw InputError(what + ": format is not '" + std::string(kFormat) + "'");
  }
  const int version = Get<int>(what, j, "version");
  if (version != kVersion) {
    throw InputError(what + ": version " + std::to_string(version) + " is not supported (only " +
                     std::to_string(kVersion) + ")");
  }
  Session s;
  s.dir = file.has_parent_path() ? file.parent_path() : fs::path(".");
  s.camera_id = j.contains("camera_id") ? Get<std::string>(what, j, "camera_id") : "";
  if (j.contains("board") && !j["board"].is_null()) s.board = Get<std::string>(what, j, "board");
  if (j.contains("gain_unit")) s.gain_unit = Get<std::string>(what, j, "gain_unit");
  if (j.contains("bit_depth")) s.bit_depth = Get<int>(what, j, "bit_depth");
  if (j.contains("black_level")) {
    s.black_level = Get<double>(what, j, "black_level");
    if (!(s.black_level >= 0)) throw InputError(what + ": black_level must be >= 0");
  }
  if (j.contains("dark_frames")) {
    s.dark_frames = Get<std::vector<std::string>>(what, j, "dark_frames");
  }
  const nlohmann::json frames = j.contains("frames") ? j["frames"] : nlohmann::json();
  if (!frames.is_array()) throw InputError(what + ": 'frames' must be an array");
  for (size_t i = 0; i < frames.size(); ++i) {
    const nlohmann::json& jf = frames[i];
    const std::string fw = what + ": frame " + std::to_string(i);
    if (!jf.is_object()) throw InputError(fw + ": not a JSON object");
    RejectUnknownKeys(fw, jf, {"file", "exposure_s", "gain", "timestamp", "bracket", "lamp_off"});
    SessionFrame f;
    f.file = Get<std::string>(fw, jf, "file");
    f.exposure_s = Get<double>(fw, jf, "exposure_s");
    f.gain = jf.contains("gain") ? Get<double>(fw, jf, "gain") : 1.0;
    f.timestamp = jf.contains("timestamp") ? Get<double>(fw, jf, "timestamp") : 0.0;
    f.bracket = jf.contains("bracket") ? Get<int>(fw, jf, "bracket") : static_cast<int>(i);
    if (jf.contains("lamp_off")) f.lamp_off = Get<std::string>(fw, jf, "lamp_off");
    s.frames.push_back(f);
  }
  s.Check(what);
  for (size_t i = 0; i < s.frames.size(); ++i) {
    if (!fs::is_regular_file(s.FramePath(i))) {
      throw InputError(what + ": frame file " + s.frames[i].file + " does not exist");
    }
    if (!s.frames[i].lamp_off.empty() && !fs::is_regular_file(s.LampOffPath(i))) {
      throw InputError(what + ": lamp-off file " + s.frames[i].lamp_off + " does not exist");
    }
  }
  for (size_t i = 0; i < s.dark_frames.size(); ++i) {
    if (!fs::is_regular_file(s.DarkFramePath(i))) {
      throw InputError(what + ": dark frame " + s.dark_frames[i] + " does not exist");
    }
  }
  if (!s.board.empty() && !fs::is_regular_file(s.BoardPath())) {
    throw InputError(what + ": board file " + s.board + " does not exist");
  }
  return s;
}

void WriteSession(const fs::path& dir, const Session& session) {
  const fs::path file = dir / "session.json";
  session.Check(file.string());
  nlohmann::json frames = nlohmann::json::array();
  for (const SessionFrame& f : session.frames) {
    if (!fs::is_regular_file(dir / f.file)) {
      throw InputError(file.string() + ": frame file " + f.file + " is not in the folder");
    }
    if (!f.lamp_off.empty() && !fs::is_regular_file(dir / f.lamp_off)) {
      throw InputError(file.string() + ": lamp-off file " + f.lamp_off + " is not in the folder");
    }
    nlohmann::json jf = {{"file", f.file},
                         {"exposure_s", f.exposure_s},
                         {"gain", f.gain},
                         {"timestamp", f.timestamp},
                         {"bracket", f.bracket}};
    if (!f.lamp_off.empty()) jf["lamp_off"] = f.lamp_off;
    frames.push_back(jf);
  }
  if (!session.board.empty() && !fs::is_regular_file(dir / session.board)) {
    throw InputError(file.string() + ": board file " + session.board + " is not in the folder");
  }
  for (const std::string& dark : session.dark_frames) {
    if (!fs::is_regular_file(dir / dark)) {
      throw InputError(file.string() + ": dark frame " + dark + " is not in the folder");
    }
  }
  nlohmann::json j = {{"format", kFormat},
                      {"version", kVersion},
                      {"camera_id", session.camera_id},
                      {"gain_unit", session.gain_unit},
                      {"frames", frames}};
  if (!session.board.empty()) j["board"] = session.board;
  if (session.bit_depth > 0) j["bit_depth"] = session.bit_depth;
  if (session.black_level >= 0) j["black_level"] = session.black_level;
  if (!session.dark_frames.empty()) j["dark_frames"] = session.dark_frames;
  WriteJsonAtomically(file, j);
}

}  // namespace gonio
