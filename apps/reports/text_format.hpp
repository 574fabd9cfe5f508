#pragma once
// Numbers and durations as the reports and progress lines print them.
#include <Eigen/Dense>
#include <string>
#include <vector>

namespace gipdyn {

std::string duration(double seconds);  // "42s", "3m07s", "2h05m"
std::string sci(double v);             // "1.23e-04", "n/a" for NaN
// "label v1 v2 ..." with every entry in sci().
std::string per_joint(const std::string& label, const Eigen::VectorXd& v);
// A Markdown table's header and rule: "| a | b |\n|---|---|\n".
std::string markdown_table_header(const std::vector<std::string>& columns);
// "joint 1" .. "joint n", the per-joint columns of a table.
std::vector<std::string> joint_columns(int n);
// Linear-interpolation quantile of the finite values (NaN if none).
double quantile(std::vector<double> v, double q);

}  // namespace gipdyn
