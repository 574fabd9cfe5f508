#include "gipdyn/io/csv.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <unordered_map>

#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include <nlohmann/json.hpp>

namespace gipdyn {
namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\"");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\"");
  return s.substr(b, e - b + 1);
}

// A log's columns are separated by commas, or, in files written by other
// tools, by tabs (spreadsheets), semicolons (spreadsheets in locales whose
// decimal mark is a comma) or runs of spaces (numpy.savetxt, MATLAB's
// save -ascii). The header decides, so that one file is read one way.
constexpr char kWhitespace = ' ';

char delimiter_of(const std::string& header_line) {
  for (char d : {',', '\t', ';'})
    if (header_line.find(d) != std::string::npos) return d;
  return kWhitespace;
}

std::vector<std::string> split(const std::string& line, char delimiter) {
  std::vector<std::string> cells;
  if (delimiter == kWhitespace) {
    size_t start = line.find_first_not_of(" \t\r");
    while (start != std::string::npos) {
      const size_t end = line.find_first_of(" \t\r", start);
      cells.push_back(line.substr(start, end == std::string::npos ? std::string::npos : end - start));
      start = end == std::string::npos ? end : line.find_first_not_of(" \t\r", end);
    }
    return cells;
  }
  size_t start = 0;
  while (true) {
    const size_t next = line.find(delimiter, start);
    cells.push_back(line.substr(start, next == std::string::npos ? std::string::npos : next - start));
    if (next == std::string::npos) break;
    start = next + 1;
  }
  return cells;
}

// A data line starting with '#' is a comment, as numpy.loadtxt reads it. ('%'
// counts only before the header, where Octave and rostopic put theirs.)
bool is_comment(const std::string& line) {
  const auto first = line.find_first_not_of(" \t");
  return first != std::string::npos && line[first] == '#';
}

// A cell's number: an optional '+' (which from_chars does not take), then from_chars.
std::from_chars_result parse_number(const std::string& cell, double& v) {
  const char* b = cell.data();
  const char* e = b + cell.size();
  if (b != e && *b == '+') ++b;
  return std::from_chars(b, e, v);
}

bool parses_as_number(const std::string& cell) {
  double v = 0.0;
  const auto res = parse_number(cell, v);
  return !cell.empty() && res.ec == std::errc() && res.ptr == cell.data() + cell.size();
}

std::ifstream open(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open '" + path + "': " + std::strerror(errno));
  return in;
}

// Where the header was found: the lines it took, and the first data line when
// reading it was the only way to know that the comment before it was the header.
struct HeaderPosition {
  long lines_read = 0;
  std::string pending_data_line;
};

// The header is the first line that is not a comment ('#' or '%'), unless
// that line is data: then it is the comment just before it (numpy.savetxt
// writes "# q1 q2 ...", rostopic "%time,field..."), and the comments before
// are a preamble.
CsvHeader parse_header(std::ifstream& in, const std::string& path, const LogColumns& log_columns,
                       HeaderPosition* position = nullptr) {
  std::string line, last_comment;
  bool found = false, after_comment = false;
  long lines_read = 0;
  while (std::getline(in, line)) {
    ++lines_read;
    // Spreadsheets saving "CSV UTF-8" start the file with a byte-order mark,
    // which would otherwise become part of the first column's name.
    if (lines_read == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    if (trim(line).empty()) continue;
    const auto first = line.find_first_not_of(" \t");
    if (line[first] == '#' || line[first] == '%') {
      last_comment = line.substr(first + 1);
      after_comment = true;
      continue;
    }
    found = true;
    break;
  }
  if (!found && !after_comment)
    throw Error("'" + path + "' is empty; expected a header row such as q1,...,qd1,...,qdd1,...,tau1,...");
  const auto all_numbers = [](const std::vector<std::string>& cells) {
    return !cells.empty() &&
           std::all_of(cells.begin(), cells.end(), [](const std::string& c) { return parses_as_number(trim(c)); });
  };
  // The comment names the columns when the next line is data: only numbers, or
  // (rostopic's "%time,field.header.frame_id,..." over "1000,base,...") as many
  // cells as the comment with some of them numbers. A header line has none.
  const auto is_data_under = [&](const std::string& comment) {
    const char delimiter = delimiter_of(comment);
    const auto cells = split(line, delimiter);
    const bool some_number =
        std::any_of(cells.begin(), cells.end(), [](const std::string& c) { return parses_as_number(trim(c)); });
    return all_numbers(cells) || (some_number && cells.size() > 1 && cells.size() == split(comment, delimiter).size());
  };
  if (!found || (after_comment && is_data_under(last_comment))) {
    if (position && found) position->pending_data_line = line;
    line = last_comment;
  }
  if (position) position->lines_read = lines_read - (position->pending_data_line.empty() ? 0 : 1);
  CsvHeader h;
  h.delimiter = delimiter_of(line);
  const auto cells = split(line, h.delimiter);
  if (all_numbers(cells))
    throw Error("'" + path + "' has no header row: its first line holds numbers ('" + trim(cells.front()) +
                "', ...); add a first line naming the columns, e.g. q1,...,qn,qd1,...,qdd1,...,tau1,...,taun");
  for (auto& c : cells) {
    const std::string name = trim(c);
    // A repeated name would make "the column q1" ambiguous: which copy was meant?
    const auto same = std::find(h.names.begin(), h.names.end(), name);
    if (!name.empty() && same != h.names.end())
      throw Error("'" + path + "' names column '" + name + "' twice (columns " +
                  std::to_string(same - h.names.begin() + 1) + " and " + std::to_string(h.names.size() + 1) +
                  " of the header); rename or remove one");
    h.names.push_back(name);
  }
  h.names = log_columns.renamed(h.names, path);
  return h;
}

// A column name in lower case without separators, its leading letters
// written the way gipdyn spells them when they are another common spelling
// of the same quantity: "dq_1", "qdot1" -> "qd1"; "ddq1", "qddot1" -> "qdd1";
// "torque1", "effort1" -> "tau1"; "pos1", "theta1" -> "q1".
std::string canonical_column(const std::string& name) {
  std::string out;
  for (char ch : name)
    if (ch != '_' && ch != '-' && ch != ' ' && ch != '.') out += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  // ROS's `rostopic echo -p` prefixes a message's fields with "field." (field.position0).
  if (out.rfind("field", 0) == 0 && out.size() > 5 && std::isalpha(static_cast<unsigned char>(out[5])))
    out.erase(0, 5);
  const size_t letters = static_cast<size_t>(
      std::find_if(out.begin(), out.end(), [](char ch) { return !std::isalpha(static_cast<unsigned char>(ch)); }) -
      out.begin());
  static const std::unordered_map<std::string, std::string> kSpellings = {
      {"pos", "q"},      {"position", "q"}, {"theta", "q"},    {"dq", "qd"},     {"qdot", "qd"},
      {"dotq", "qd"},    {"vel", "qd"},     {"velocity", "qd"}, {"ddq", "qdd"},  {"qddot", "qdd"},
      {"acc", "qdd"},    {"accel", "qdd"},  {"acceleration", "qdd"}, {"torque", "tau"}, {"effort", "tau"}};
  const auto it = kSpellings.find(out.substr(0, letters));
  return it == kSpellings.end() ? out : it->second + out.substr(letters);
}

// Names the file's columns, and one that differs from the wanted one only in
// case, separators or a common spelling ("Q_1" or "pos1" for "q1", "dq1" for
// "qd1"), so that a log with its own naming is fixed by renaming, not guessed at.
std::string missing_column_message(const std::string& path, const std::string& wanted, const CsvHeader& header,
                                   const LogColumns& log_columns) {
  std::string message = "'" + path + "' has no column '" + wanted + "'";
  if (const std::optional<JointColumn> joint_column = split_joint_column(wanted);
      joint_column && !log_columns.is_default()) {  // name the column the log's names give it
    const std::string log_name = log_columns.log_name(joint_column->quantity, joint_column->joint);
    if (log_name != wanted)
      return "'" + path + "' has no column '" + log_name + "' (" + wanted + " under the log's column names, LogColumns)";
    return message + " (LogColumns keeps gipdyn's name for " + joint_column->quantity +
           ": give the log's name of it there)";
  }
  for (const auto& name : header.names)
    if (canonical_column(name) == canonical_column(wanted))
      return message + " (its column '" + name + "' looks like it: rename it)";
  const size_t shown = std::min<size_t>(header.names.size(), 10);
  std::string listed = joined({header.names.begin(), header.names.begin() + static_cast<std::ptrdiff_t>(shown)});
  if (shown < header.names.size()) listed += ", ... (" + std::to_string(header.names.size()) + " in all)";
  return message + " (its columns: " + listed + "); add or rename it, or check the joint types";
}

}  // namespace

void require_joints_counted_from_one(const CsvHeader& header, const std::string& path) {
  for (const auto& name : header.names)
    if (canonical_column(name) == "q0")
      throw Error("'" + path + "' has a column '" + name +
                  "': its joints are counted from 0, gipdyn's from 1 (q1 is the first joint); rename the columns "
                  "q0..q(n-1) to q1..qn, and qd, qdd and tau likewise, or say what the log calls them (LogColumns, "
                  "e.g. q=" + name.substr(0, name.find_first_of("0123456789")) + "{i0})");
}

bool CsvHeader::has(const std::string& name) const {
  return std::find(names.begin(), names.end(), name) != names.end();
}

CsvHeader read_csv_header(const std::string& path, const LogColumns& columns) {
  auto in = open(path);
  return parse_header(in, path, columns);
}

Eigen::MatrixXd read_csv_columns(const std::string& path, const std::vector<std::string>& columns,
                                 const LogColumns& log_columns) {
  auto in = open(path);
  HeaderPosition position;
  const CsvHeader header = parse_header(in, path, log_columns, &position);
  std::unordered_map<std::string, size_t> index;
  for (size_t k = 0; k < header.names.size(); ++k) index.emplace(header.names[k], k);
  std::vector<size_t> wanted;
  for (const auto& c : columns) {
    auto it = index.find(c);
    if (it == index.end()) throw Error(missing_column_message(path, c, header, log_columns));
    wanted.push_back(it->second);
  }

  std::vector<double> values;
  long line_no = position.lines_read;
  Eigen::Index rows = 0;
  const auto read_row = [&](const std::string& line) {
    ++line_no;
    if (trim(line).empty() || is_comment(line)) return;
    const auto cells = split(line, header.delimiter);
    if (cells.size() != header.names.size())
      throw Error("'" + path + "' line " + std::to_string(line_no) + " has " + std::to_string(cells.size()) +
                  " cells but the header has " + std::to_string(header.names.size()) +
                  (cells.size() < header.names.size() ? " (truncated file?)" : " (a stray separator or a merged row?)"));
    for (size_t k = 0; k < wanted.size(); ++k) {
      const std::string cell = trim(cells[wanted[k]]);
      double v = 0.0;
      const auto res = parse_number(cell, v);
      const char* e = cell.data() + cell.size();
      if (!cell.empty() && res.ec == std::errc::result_out_of_range && res.ptr == e)
        throw Error("'" + path + "' line " + std::to_string(line_no) + ", column '" + columns[k] + "': '" + cell +
                    "' is outside the range of a double (about 1e308)");
      if (cell.empty() || res.ec != std::errc() || res.ptr != e)
        throw Error("'" + path + "' line " + std::to_string(line_no) + ", column '" + columns[k] + "': '" + cell +
                    "' is not a number" +
                    (header.delimiter != ',' && cell.find(',') != std::string::npos
                         ? " (a decimal comma? gipdyn reads '.' as the decimal mark: save the log with '.')"
                         : ""));
      if (!std::isfinite(v))
        throw Error("'" + path + "' line " + std::to_string(line_no) + ", column '" + columns[k] +
                    "' is NaN or Inf; remove or repair that row");
      values.push_back(v);
    }
    ++rows;
  };
  if (!position.pending_data_line.empty()) read_row(position.pending_data_line);
  std::string line;
  while (std::getline(in, line)) read_row(line);
  Eigen::MatrixXd out(rows, static_cast<Eigen::Index>(columns.size()));
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < out.cols(); ++c) out(r, c) = values[static_cast<size_t>(r * out.cols() + c)];
  return out;
}

namespace {

// Throws unless every value is finite and there is one name per column.
void require_writable(const std::string& path, const std::vector<std::string>& header, const Eigen::MatrixXd& data) {
  if (static_cast<Eigen::Index>(header.size()) != data.cols())
    throw Error("write_csv: " + std::to_string(header.size()) + " column names for " + std::to_string(data.cols()) +
                " columns");
  // No NaN or Inf ever reaches a file: say which value, and write nothing.
  for (Eigen::Index c = 0; c < data.cols(); ++c)
    for (Eigen::Index r = 0; r < data.rows(); ++r)
      if (!std::isfinite(data(r, c)))
        throw Error("'" + path + "' would get a non-finite value (NaN or Inf) in data row " + std::to_string(r + 1) +
                    ", column '" + header[static_cast<size_t>(c)] +
                    "'; nothing was written: check the inputs or options that produced that row");
}

FileContent csv_content(const std::string& path, const std::vector<std::string>& header, const Eigen::MatrixXd& data) {
  require_writable(path, header, data);
  return {path, [&header, &data](std::ostream& out) {
            for (size_t k = 0; k < header.size(); ++k) out << (k ? "," : "") << header[k];
            out << "\n";
            char buf[64];
            for (Eigen::Index r = 0; r < data.rows(); ++r) {
              for (Eigen::Index c = 0; c < data.cols(); ++c) {
                const auto res = std::to_chars(buf, buf + sizeof(buf), data(r, c));  // shortest round-trip form
                if (c) out << ',';
                out.write(buf, res.ptr - buf);
              }
              out << '\n';
            }
          }};
}

}  // namespace

void write_csv(const std::string& path, const std::vector<std::string>& header, const Eigen::MatrixXd& data) {
  write_files_atomically({csv_content(path, header, data)});
}

void write_csv_with_sidecar(const std::string& path, const std::vector<std::string>& header,
                            const Eigen::MatrixXd& data, const nlohmann::json& sidecar) {
  // Both temporaries first, the sidecar renamed last: a failure leaves the old pair as it was.
  write_files_atomically({csv_content(path, header, data),
                          {path + ".json", [&sidecar](std::ostream& out) { out << sidecar.dump(2) << "\n"; }}});
}

}  // namespace gipdyn
