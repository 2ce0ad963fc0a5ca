// File helpers: every output is written to a temporary name in the same folder and renamed
// into place, so a failed run never leaves a half-written result.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "common/interrupt.h"  // TemporaryGuard: every temporary below is guarded

namespace gonio {

// Calls write(tmp_path) where tmp_path is a sibling of `path` with the same extension (so
// writers that choose the format by extension, such as cv::imwrite, still work), then renames
// it to `path`. If write throws or returns false, the temporary is removed and the error
// propagates (InputError naming `path` for a false return). After SIGINT/SIGTERM it throws
// Interrupted (common/interrupt.h) before the rename, the temporary removed.
void WriteAtomically(const std::filesystem::path& path,
                     const std::function<bool(const std::filesystem::path& tmp_path)>& write);

void WriteTextAtomically(const std::filesystem::path& path, const std::string& text);

// Writes pretty-printed JSON. Objects get a "provenance" member (tool, version, command line).
void WriteJsonAtomically(const std::filesystem::path& path, nlohmann::json j);

// Reads a JSON file; InputError naming the file on a missing file or a parse error.
nlohmann::json ReadJsonFile(const std::filesystem::path& path);

std::string ReadTextFile(const std::filesystem::path& path);

// j[key], or j[old_key] in a file written before the key was renamed (docs/formats.md
// "Renamed keys": the lamp was called "light"). Neither: json::at's out_of_range for `key`.
const nlohmann::json& AtKeyOrOld(const nlohmann::json& j, const char* key, const char* old_key);

// An output path the system can create: at most PATH_MAX - 1 bytes, each name at most NAME_MAX;
// InputError naming `option` otherwise (checked before any work, not met at the end).
void CheckOutputPathLength(const std::filesystem::path& path, const std::string& option);

// Creates a folder (and parents); InputError naming it when that is impossible.
void EnsureDirectory(const std::filesystem::path& dir);

// A folder written as a whole (docs/pipeline.md "Checks"): the writer fills tmp(), a temporary
// sibling of `dir`; Commit() puts it in place of `dir` (a previous folder is moved aside first
// and removed last), so `dir` is the old folder or the new one, never a mix. Without Commit (a
// failure, an interrupt) the temporary is removed and `dir` is untouched.
class FolderTransaction {
 public:
  // InputError before any work when `dir` cannot be replaced: an existing file, or a non-empty
  // folder without `marker` (the file every previous output of the command holds; empty: no
  // folder is ever replaced, only an empty one), or a parent folder that does not exist.
  static void CheckTarget(const std::filesystem::path& dir, const std::string& marker);

  // CheckTarget, then creates the temporary folder.
  FolderTransaction(const std::filesystem::path& dir, const std::string& marker);
  ~FolderTransaction();
  FolderTransaction(const FolderTransaction&) = delete;
  FolderTransaction& operator=(const FolderTransaction&) = delete;

  const std::filesystem::path& tmp() const { return tmp_; }
  void Commit();

 private:
  std::filesystem::path dir_, tmp_;
  TemporaryGuard guard_;
  bool committed_ = false;
};

}  // namespace gonio
