#include "gipdyn/joint_types.hpp"

#include <cctype>

#include "gipdyn/error.hpp"

namespace gipdyn {

JointTypes JointTypes::parse(const std::string& text) {
  if (text.empty() || static_cast<int>(text.size()) > kMaxJoints) {
    throw Error("joint string '" + text + "' must have 1 to " + std::to_string(kMaxJoints) +
                " characters, one 'R' (revolute) or 'P' (prismatic) per joint, e.g. RRPR");
  }
  JointTypes out;
  for (size_t k = 0; k < text.size(); ++k) {
    const char c = static_cast<char>(std::toupper(static_cast<unsigned char>(text[k])));
    if (c == 'R') {
      out.types_.push_back(JointType::Revolute);
    } else if (c == 'P') {
      out.types_.push_back(JointType::Prismatic);
    } else {
      throw Error("joint string '" + text + "' has '" + std::string(1, text[k]) + "' at position " +
                  std::to_string(k + 1) + "; use only 'R' (revolute) and 'P' (prismatic)");
    }
  }
  return out;
}

int JointTypes::num_revolute() const {
  int count = 0;
  for (JointType t : types_) count += (t == JointType::Revolute);
  return count;
}

std::string JointTypes::str() const {
  std::string s;
  for (JointType t : types_) s.push_back(t == JointType::Revolute ? 'R' : 'P');
  return s;
}

std::vector<std::string> input_column_names(int n) {
  std::vector<std::string> names;
  for (const char* prefix : {"q", "qd", "qdd"})
    for (const auto& name : joint_column_names(prefix, n)) names.push_back(name);
  return names;
}

std::vector<std::string> joint_column_names(const std::string& prefix, int n, const std::string& suffix) {
  std::vector<std::string> names;
  for (int i = 1; i <= n; ++i) names.push_back(prefix + std::to_string(i) + suffix);
  return names;
}

std::vector<std::string> torque_column_names(int n, const std::string& suffix) {
  return joint_column_names("tau", n, suffix);
}

std::vector<std::string> external_torque_column_names(int n, const std::string& suffix) {
  return joint_column_names("ext", n, suffix);
}

}  // namespace gipdyn
