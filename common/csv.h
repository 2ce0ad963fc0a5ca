// A small CSV reader addressed by header names, with errors that name file, line and column.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace gonio {

class CsvTable {
 public:
  // Parses comma-separated text with a header line. Blank lines and lines starting with '#'
  // are skipped. InputError naming `source` on ragged rows or an empty table.
  static CsvTable Parse(const std::string& text, const std::string& source);
  static CsvTable Read(const std::filesystem::path& path);

  const std::vector<std::string>& header() const { return header_; }
  size_t num_rows() const { return rows_.size(); }
  const std::string& source() const { return source_; }

  // Column index by name; nullopt when absent.
  std::optional<size_t> Find(const std::string& name) const;
  // Column index by name; InputError "FILE: missing column 'name'" when absent.
  size_t Require(const std::string& name) const;

  const std::string& Cell(size_t row, size_t col) const { return rows_[row][col]; }
  // The cell as a finite number; InputError naming file, line and column otherwise.
  double Number(size_t row, size_t col) const;
  // 1-based line number in the source of a data row (for messages).
  size_t LineOf(size_t row) const { return lines_[row]; }

 private:
  std::string source_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<size_t> lines_;
};

// Quotes a field if it contains a comma or quote.
std::string CsvField(const std::string& s);

}  // namespace gonio
