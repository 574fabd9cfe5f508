#pragma once
// The joint-type string ("RRPR") that is all the GIP kernel knows about a robot.
#include <string>
#include <vector>

namespace gipdyn {

enum class JointType { Revolute, Prismatic };

class JointTypes {
 public:
  static constexpr int kMaxJoints = 12;

  // Parses a string of 'R'/'P' characters (case-insensitive), 1 to 12 long.
  // Throws gipdyn::Error with the offending character otherwise.
  static JointTypes parse(const std::string& text);

  int size() const { return static_cast<int>(types_.size()); }
  JointType operator[](int i) const { return types_[static_cast<size_t>(i)]; }
  bool is_revolute(int i) const { return types_[static_cast<size_t>(i)] == JointType::Revolute; }
  int num_revolute() const;
  int num_prismatic() const { return size() - num_revolute(); }
  std::string str() const;

 private:
  std::vector<JointType> types_;
};

// "PREFIX1".."PREFIXn" with an optional suffix: one column per joint.
std::vector<std::string> joint_column_names(const std::string& prefix, int num_joints, const std::string& suffix = "");
// The columns of a log of num_joints joints: "q1".."qn", "qd1".."qdn", "qdd1".."qddn".
std::vector<std::string> input_column_names(int num_joints);
// "tau1".."taun", with an optional suffix ("_true", "_hat", "_std").
std::vector<std::string> torque_column_names(int num_joints, const std::string& suffix = "");
// "ext1".."extn": the external torque on each joint (contact detection), with
// an optional suffix ("_true": a simulated log's ground truth).
std::vector<std::string> external_torque_column_names(int num_joints, const std::string& suffix = "");

}  // namespace gipdyn
