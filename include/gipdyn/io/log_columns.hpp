#pragma once
// How a log names its joint columns. gipdyn's own names are q1..qn, qd1..qdn,
// qdd1..qddn and tau1..taun; a log exported by another tool names them its
// own way (ROS joint_states: position_0, velocity_0, effort_0). LogColumns
// says how, one pattern per quantity, and the CSV reader renames the log's
// columns to gipdyn's as it reads the header, so every reader and command
// sees the same names whatever the file calls them.
#include <optional>
#include <string>
#include <vector>

namespace gipdyn {

struct LogColumns {
  // In each pattern "{i}" stands for the joint's number counted from 1 and
  // "{i0}" for it counted from 0: "position_{i0}" names joint 1's position
  // position_0. Exactly one of them per pattern.
  std::string q = "q{i}";
  std::string qd = "qd{i}";
  std::string qdd = "qdd{i}";
  std::string tau = "tau{i}";

  // Throws gipdyn::Error naming the field: a pattern without exactly one
  // {i} or {i0}, or two quantities under one pattern.
  void validate() const;
  // gipdyn's own names: nothing to rename.
  bool is_default() const;
  // The log's name of joint `joint` (counted from 1) of `quantity` (q, qd, qdd or tau).
  std::string log_name(const std::string& quantity, int joint) const;
  // The header's names with every column that a pattern matches renamed to
  // gipdyn's name of it (position_0 -> q1); the others as they are. Throws
  // gipdyn::Error, naming the file `path`, where two of its columns would
  // get the same name (a log with both position_0 and q1 under q=position_{i0}).
  std::vector<std::string> renamed(const std::vector<std::string>& names, const std::string& path) const;
};

// The quantities a LogColumns names, in the order of its fields: q, qd, qdd, tau.
const std::vector<std::string>& log_column_quantities();

// gipdyn's name of a joint column split into its quantity and joint number
// ("qd2": {"qd", 2}); nullopt for any other name.
struct JointColumn {
  std::string quantity;
  int joint = 0;
};
std::optional<JointColumn> split_joint_column(const std::string& name);

// A LogColumns from "q=position_{i0},qd=velocity_{i0},tau=effort_{i0}"
// (quantities not named keep gipdyn's names), or from the JSON file at that
// path ({"q": "position_{i0}", ...}), validated. "" is the default. Throws
// gipdyn::Error naming the problem and the expected form.
LogColumns parse_log_columns(const std::string& spec);

}  // namespace gipdyn
