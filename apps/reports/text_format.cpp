#include "reports/text_format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace gipdyn {

std::string duration(double s) {
  char buf[32];
  if (s < 60) std::snprintf(buf, sizeof buf, "%.0fs", s);
  else if (s < 3600) std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  else std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(s) / 3600, (static_cast<int>(s) % 3600) / 60);
  return buf;
}

std::string markdown_table_header(const std::vector<std::string>& columns) {
  std::string header = "|", rule = "|";
  for (const std::string& c : columns) {
    header += " " + c + " |";
    rule += "---|";
  }
  return header + "\n" + rule + "\n";
}

std::vector<std::string> joint_columns(int n) {
  std::vector<std::string> columns;
  for (int j = 1; j <= n; ++j) columns.push_back("joint " + std::to_string(j));
  return columns;
}

std::string sci(double v) {
  if (std::isnan(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2e", v);
  return buf;
}

std::string per_joint(const std::string& label, const Eigen::VectorXd& v) {
  std::string line = label;
  for (Eigen::Index j = 0; j < v.size(); ++j) line += " " + sci(v(j));
  return line;
}

double quantile(std::vector<double> v, double q) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace gipdyn
