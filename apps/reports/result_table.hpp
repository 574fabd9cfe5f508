#pragma once
// A small CSV table of experiment results that survives interruption: every
// change rewrites the file atomically, and an existing file is read back so
// that a restarted experiment skips what is already recorded.
#include <string>
#include <vector>

namespace gipdyn {

class ResultTable {
 public:
  // Reads `path` if it exists (its header must equal `columns`), else starts empty.
  // Throws gipdyn::Error for a file with other columns or a malformed row.
  ResultTable(std::string path, std::vector<std::string> columns);

  const std::vector<std::string>& columns() const { return columns_; }
  const std::vector<std::vector<std::string>>& rows() const { return rows_; }
  int column(const std::string& name) const;  // throws if absent

  // Whether some row has these values in these columns.
  bool contains(const std::vector<std::pair<std::string, std::string>>& key) const;
  // Appends the rows and rewrites the file atomically.
  void append(const std::vector<std::vector<std::string>>& rows);

 private:
  std::string path_;
  std::vector<std::string> columns_;
  std::vector<std::vector<std::string>> rows_;
};

std::string format_number(double v);  // "%.10g", "nan" for NaN

}  // namespace gipdyn
