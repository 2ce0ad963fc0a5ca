#include "common/csv.h"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "common/error.h"
#include "common/io.h"

namespace gonio {
namespace {

std::string Trim(const std::string& s) {
  size_t b = s.find_first_not_of(" \t\r");
  size_t e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

std::vector<std::string> SplitLine(const std::string& line) {
  std::vector<std::string> fields;
  std::string cur;
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cur += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cur += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.push_back(Trim(cur));
      cur.clear();
    } else {
      cur += c;
    }
  }
  fields.push_back(Trim(cur));
  return fields;
}

}  // namespace

CsvTable CsvTable::Parse(const std::string& text, const std::string& source) {
  CsvTable t;
  t.source_ = source;
  std::istringstream in(text);
  std::string line;
  size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    auto fields = SplitLine(line);
    if (t.header_.empty()) {
      t.header_ = fields;
      continue;
    }
    if (fields.size() != t.header_.size()) {
      throw InputError(source + ": line " + std::to_string(line_no) + " has " +
                       std::to_string(fields.size()) + " fields, the header has " +
                       std::to_string(t.header_.size()));
    }
    t.rows_.push_back(std::move(fields));
    t.lines_.push_back(line_no);
  }
  if (t.header_.empty()) throw InputError(source + ": empty CSV (no header line)");
  return t;
}

CsvTable CsvTable::Read(const std::filesystem::path& path) {
  return Parse(ReadTextFile(path), path.string());
}

std::optional<size_t> CsvTable::Find(const std::string& name) const {
  for (size_t i = 0; i < header_.size(); ++i) {
    if (header_[i] == name) return i;
  }
  return std::nullopt;
}

size_t CsvTable::Require(const std::string& name) const {
  auto col = Find(name);
  if (!col) throw InputError(source_ + ": missing column '" + name + "'");
  return *col;
}

double CsvTable::Number(size_t row, size_t col) const {
  const std::string& cell = rows_[row][col];
  char* end = nullptr;
  double v = std::strtod(cell.c_str(), &end);
  if (cell.empty() || end != cell.c_str() + cell.size() || !std::isfinite(v)) {
    throw InputError(source_ + ": line " + std::to_string(lines_[row]) + ", column '" +
                     header_[col] + "': '" + cell + "' is not a finite number");
  }
  return v;
}

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + "\"";
}

}  // namespace gonio
