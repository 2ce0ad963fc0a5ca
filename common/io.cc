#include "common/io.h"

#include <unistd.h>
#include <atomic>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <system_error>

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
  std::error_code ec;
  fs::rename(tmp_path, path, ec);
  if (ec) {
    fs::remove(tmp_path, ec);
    throw InputError(path.string() + ": could not be written (" + ec.message() + ")");
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
  WriteTextAtomically(path, j.dump(2) + "\n");
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

namespace {

// Paths being written right now, removed by RemoveTemporaries() on SIGINT/SIGTERM.
std::mutex& TemporariesMutex() {
  static std::mutex m;
  return m;
}
std::set<std::string>& Temporaries() {
  static std::set<std::string> paths;
  return paths;
}

}  // namespace

TemporaryGuard::TemporaryGuard(fs::path path) : path_(std::move(path)) {
  std::lock_guard<std::mutex> lock(TemporariesMutex());
  Temporaries().insert(path_.string());
}

TemporaryGuard::~TemporaryGuard() {
  std::lock_guard<std::mutex> lock(TemporariesMutex());
  Temporaries().erase(path_.string());
}

void RemoveTemporaries() {
  // try_lock: the signal may have arrived while a guard held the lock; then leave the files
  // rather than deadlock in the handler.
  if (!TemporariesMutex().try_lock()) return;
  for (const auto& p : Temporaries()) {
    std::error_code ec;
    fs::remove_all(p, ec);
  }
  TemporariesMutex().unlock();
}

void EnsureDirectory(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw InputError(dir.string() + ": cannot create folder" +
                     (ec ? " (" + ec.message() + ")" : ""));
  }
}

}  // namespace gonio
