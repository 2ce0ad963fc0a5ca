// File helpers: every output is written to a temporary name in the same folder and renamed
// into place, so a failed run never leaves a half-written result.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

namespace gonio {

// Calls write(tmp_path) where tmp_path is a sibling of `path` with the same extension (so
// writers that choose the format by extension, such as cv::imwrite, still work), then renames
// it to `path`. If write throws or returns false, the temporary is removed and the error
// propagates (InputError naming `path` for a false return).
void WriteAtomically(const std::filesystem::path& path,
                     const std::function<bool(const std::filesystem::path& tmp_path)>& write);

void WriteTextAtomically(const std::filesystem::path& path, const std::string& text);

// Writes pretty-printed JSON. Objects get a "provenance" member (tool, version, command line).
void WriteJsonAtomically(const std::filesystem::path& path, nlohmann::json j);

// Reads a JSON file; InputError naming the file on a missing file or a parse error.
nlohmann::json ReadJsonFile(const std::filesystem::path& path);

std::string ReadTextFile(const std::filesystem::path& path);

// Marks a temporary file or folder for removal by RemoveTemporaries() while it exists: the
// outputs being written when the user interrupts a run are removed, not left half-written.
class TemporaryGuard {
 public:
  explicit TemporaryGuard(std::filesystem::path path);
  ~TemporaryGuard();
  TemporaryGuard(const TemporaryGuard&) = delete;
  TemporaryGuard& operator=(const TemporaryGuard&) = delete;

 private:
  std::filesystem::path path_;
};

// Removes every guarded temporary (called by the CLI's SIGINT/SIGTERM handler before it exits).
void RemoveTemporaries();

// Creates a folder (and parents); InputError naming it when that is impossible.
void EnsureDirectory(const std::filesystem::path& dir);

}  // namespace gonio
