#include "common/io.h"

#include <limits.h>
#include <unistd.h>
#include <atomic>
#include <fstream>
#include <sstream>
#include <system_error>

#include <fmt/format.h>

#include "common/error.h"
#include "common/provenance.h"

namespace fs = std::filesystem;

namespace gonio {

void WriteAtomically(const fs::path& path,
                     const std::function<bool(const fs::path& tmp_path)>& write) {
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (!fs::is_directory(dir)) {
    throw InputError(path.string() + ": output folder " + dir.string() + " does not exist");
  }
  // Same extension so format-by-extension writers keep working; pid and a counter keep
  // parallel writers apart; a short name so a long (but legal) output name still works.
  static std::atomic<unsigned> counter{0};
  const fs::path tmp_path = dir / (".gonio-" + std::to_string(::getpid()) + "-" +
                                   std::to_string(counter++) + path.extension().string());
  const TemporaryGuard guard(tmp_path);
  bool ok = false;
  try {
    ok = write(tmp_path);
    if (ok) {
      HoldTemporaryForTests(tmp_path);
      ThrowIfInterrupted();  // the last moment to leave the old output as it was
    }
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp_path, ec);
    throw;
  }
  if (!ok) {
    std::error_code ec;
    fs::remove(tmp_path, ec);
    throw InputError(path.string() + ": could not be written");
  }
  std::error_code rename_error;
  fs::rename(tmp_path, path, rename_error);
  if (rename_error) {
    std::error_code ec;
    fs::remove(tmp_path, ec);
    throw InputError(path.string() + ": could not be written (" + rename_error.message() + ")");
  }
}

void WriteTextAtomically(const fs::path& path, const std::string& text) {
  WriteAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    out.close();
    return static_cast<bool>(out);
  });
}

void WriteJsonAtomically(const fs::path& path, nlohmann::json j) {
  if (j.is_object() && !j.contains("provenance")) j["provenance"] = Provenance();
  // File names and the command line need not be UTF-8 (Linux names are bytes): their invalid
  // bytes become U+FFFD rather than an exception that loses the whole output.
  WriteTextAtomically(path, j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

std::string ReadTextFile(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path.string() + ": no such file");
  if (fs::is_directory(path, ec)) throw InputError(path.string() + ": is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot be opened for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

nlohmann::json ReadJsonFile(const fs::path& path) {
  const std::string text = ReadTextFile(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path.string() + ": not valid JSON (byte " + std::to_string(e.byte) + ")");
  } catch (const nlohmann::json::out_of_range&) {
    // The parser's own error for a number beyond double's range (e.g. 1e999).
    throw InputError(path.string() + ": not valid JSON (a number is out of range)");
  } catch (const nlohmann::json::exception& e) {
    // Any other parser error is bad input too, not an internal error.
    throw InputError(path.string() + ": unusable JSON (" + e.what() + ")");
  }
}

const nlohmann::json& AtKeyOrOld(const nlohmann::json& j, const char* key, const char* old_key) {
  if (!j.contains(key) && j.contains(old_key)) return j.at(old_key);
  return j.at(key);
}

void CheckOutputPathLength(const fs::path& path, const std::string& option) {
  // The temporaries beside an output add a few characters to its folder, never to its name
  // (WriteAtomically, FolderTransaction), so the system's own limits are the ones to check.
  const size_t total = fs::absolute(path).string().size();
  if (total >= PATH_MAX) {
    throw InputError(fmt::format("{}: a path of {} characters; the system takes at most {}", option,
                                 total, PATH_MAX - 1));
  }
  for (const auto& part : path) {
    if (part.string().size() > NAME_MAX) {
      throw InputError(
          fmt::format("{}: a name of {} characters ({}...); the system takes at most {}", option,
                      part.string().size(), part.string().substr(0, 40), NAME_MAX));
    }
  }
}

void EnsureDirectory(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw InputError(dir.string() + ": cannot create folder" +
                     (ec ? " (" + ec.message() + ")" : ""));
  }
}

namespace {

fs::path FolderTemporary(const fs::path& dir) {
  static std::atomic<unsigned> counter{0};
  const fs::path abs = fs::absolute(dir);
  return abs.parent_path() /
         (".gonio-tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
}

}  // namespace

void FolderTransaction::CheckTarget(const fs::path& dir, const std::string& marker) {
  if (dir.empty()) throw InputError("--out: empty path");
  CheckOutputPathLength(dir, "--out");
  std::error_code ec;
  const fs::path parent = fs::absolute(dir).parent_path();
  if (!fs::is_directory(parent, ec)) {
    throw InputError(dir.string() + ": output folder " + parent.string() + " does not exist");
  }
  if (!fs::exists(dir, ec)) return;
  if (!fs::is_directory(dir, ec)) throw InputError(dir.string() + ": exists and is not a folder");
  if (fs::is_empty(dir, ec)) return;
  if (marker.empty()) {
    throw InputError(dir.string() + ": exists and is not empty; choose a new folder for --out");
  }
  if (!fs::exists(dir / marker, ec)) {
    throw InputError(dir.string() + ": not empty and not a previous output (no " + marker +
                     "); choose another --out");
  }
}

FolderTransaction::FolderTransaction(const fs::path& dir, const std::string& marker)
    : dir_(fs::absolute(dir)), tmp_(FolderTemporary(dir)), guard_(tmp_) {
  CheckTarget(dir, marker);
  std::error_code ec;
  fs::remove_all(tmp_, ec);
  try {
    EnsureDirectory(tmp_);
    HoldTemporaryForTests(tmp_);
  } catch (...) {  // the destructor does not run for a constructor that throws
    fs::remove_all(tmp_, ec);
    throw;
  }
}

FolderTransaction::~FolderTransaction() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(tmp_, ec);
}

void FolderTransaction::Commit() {
  ThrowIfInterrupted();  // the last moment to leave the old folder as it was
  const fs::path old = tmp_.string() + "-old";
  std::error_code ec;
  if (fs::exists(dir_, ec)) {
    fs::rename(dir_, old, ec);
    if (ec) throw InputError(dir_.string() + ": cannot be replaced (" + ec.message() + ")");
  }
  fs::rename(tmp_, dir_, ec);
  if (ec) {
    std::error_code restore;
    if (fs::exists(old, restore)) fs::rename(old, dir_, restore);
    throw InputError(dir_.string() + ": could not be written (" + ec.message() + ")");
  }
  committed_ = true;
  fs::remove_all(old, ec);
}

}  // namespace gonio
