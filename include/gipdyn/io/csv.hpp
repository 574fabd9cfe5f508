#pragma once
// Numeric CSV with a header row. Only the requested columns are parsed, so
// extra (even non-numeric) columns are ignored. Errors name the file, the line
// and the column. The header's separator is the file's: a comma, else a tab,
// else a semicolon, else runs of spaces. A byte-order mark, a preamble of
// comment lines ('#' or '%') and a header written as the last of them
// ("# q1 q2 ...", numpy.savetxt) are accepted; later lines starting with '#'
// are skipped. The decimal mark is '.'.
#include <Eigen/Dense>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/io/log_columns.hpp"

namespace gipdyn {

struct CsvHeader {
  std::vector<std::string> names;
  char delimiter = ',';  // ' ' stands for runs of spaces or tabs
  bool has(const std::string& name) const;
};

// The header's names, those that `columns` matches renamed to gipdyn's (LogColumns::renamed).
CsvHeader read_csv_header(const std::string& path, const LogColumns& columns = {});

// Throws gipdyn::Error when the header counts joints from 0 (a column q0, or
// another spelling of it such as pos_0): gipdyn's joints are q1..qn, and
// reading q1.. of such a log would shift every joint by one.
void require_joints_counted_from_one(const CsvHeader& header, const std::string& path);

// Reads the named columns (in the given order) into a rows x columns matrix.
// Throws gipdyn::Error for a missing file or column, a header that names a
// column twice, a row with more or fewer cells than the header, a non-numeric
// cell, a number outside the range of a double, or NaN/Inf.
// `columns` are gipdyn's names; `log_columns` says what the file calls them.
Eigen::MatrixXd read_csv_columns(const std::string& path, const std::vector<std::string>& columns,
                                 const LogColumns& log_columns = {});

// Writes header + rows atomically, with enough digits to round-trip doubles.
// Throws gipdyn::Error, writing nothing, if any value is NaN or Inf.
void write_csv(const std::string& path, const std::vector<std::string>& header, const Eigen::MatrixXd& data);

// The CSV and PATH.json (how it was made) together: both files or neither.
void write_csv_with_sidecar(const std::string& path, const std::vector<std::string>& header,
                            const Eigen::MatrixXd& data, const nlohmann::json& sidecar);

}  // namespace gipdyn
