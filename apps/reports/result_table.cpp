#include "reports/result_table.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"

namespace gipdyn {
namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) out.push_back(cell);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

}  // namespace

std::string format_number(double v) {
  if (std::isnan(v)) return "nan";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

ResultTable::ResultTable(std::string path, std::vector<std::string> columns)
    : path_(std::move(path)), columns_(std::move(columns)) {
  if (!std::filesystem::exists(path_)) return;
  std::ifstream in(path_);
  std::string line;
  if (!std::getline(in, line)) return;
  if (split(line) != columns_) {
    std::string expected;
    for (const auto& c : columns_) expected += (expected.empty() ? "" : ",") + c;
    throw Error("'" + path_ + "' has columns '" + line + "' instead of '" + expected +
                "'; it belongs to another experiment: use another --out or delete it");
  }
  int lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty()) continue;
    auto cells = split(line);
    if (cells.size() != columns_.size())
      throw Error("'" + path_ + "' line " + std::to_string(lineno) + " has " + std::to_string(cells.size()) +
                  " cells instead of " + std::to_string(columns_.size()) + "; repair or delete the file");
    rows_.push_back(std::move(cells));
  }
}

int ResultTable::column(const std::string& name) const {
  for (size_t c = 0; c < columns_.size(); ++c)
    if (columns_[c] == name) return static_cast<int>(c);
  throw Error("result table '" + path_ + "' has no column '" + name + "'");
}

bool ResultTable::contains(const std::vector<std::pair<std::string, std::string>>& key) const {
  std::vector<std::pair<int, std::string>> k;
  for (const auto& [name, value] : key) k.emplace_back(column(name), value);
  for (const auto& row : rows_) {
    bool match = true;
    for (const auto& [c, v] : k) match = match && row[static_cast<size_t>(c)] == v;
    if (match) return true;
  }
  return false;
}

void ResultTable::append(const std::vector<std::vector<std::string>>& rows) {
  for (const auto& r : rows) {
    if (r.size() != columns_.size()) throw Error("result table: row with the wrong number of cells");
    rows_.push_back(r);
  }
  write_file_atomically(path_, [&](std::ostream& out) {
    for (size_t c = 0; c < columns_.size(); ++c) out << (c ? "," : "") << columns_[c];
    out << "\n";
    for (const auto& r : rows_) {
      for (size_t c = 0; c < r.size(); ++c) out << (c ? "," : "") << r[c];
      out << "\n";
    }
  });
}

}  // namespace gipdyn
