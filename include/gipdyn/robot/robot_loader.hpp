#pragma once
// Robots by name or file: the built-in models, a JSON DH description
// (docs/robot-format.md) and URDF (urdfdom + kdl_parser).
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gipdyn/robot/robot_model.hpp"

namespace gipdyn {

// Built-in models (numbers and their sources in src/robot/builtin_robots.cpp).
RobotModel scara_robot();  // Adept One-like SCARA, RRPR
RobotModel ur10_robot();   // Universal Robots UR10, 6R
const std::vector<std::string>& builtin_robot_names();

RobotModel load_robot_json(const std::string& path);
RobotModel robot_from_json(const nlohmann::json& description, const std::string& source);
// A serial chain from the URDF's root link to `tip_link`, or to its single
// leaf when tip_link is empty (a tree that branches then needs a tip_link).
// Fixed joints are merged into the preceding link. Links off the chain (a
// gripper's fingers beyond the tip, a sensor on a link) ride rigidly on the
// chain link they hang from, their own joints at position zero. Floating and
// planar joints on the chain are rejected.
RobotModel load_robot_urdf(const std::string& path, const std::string& tip_link = "");
// The same from URDF text; `source` names it in errors.
RobotModel robot_from_urdf(const std::string& xml, const std::string& source, const std::string& tip_link = "");

// A robot as model files store it: {"dh": description} or {"urdf": text, "gravity": [...]}.
nlohmann::json robot_to_storable_json(const RobotModel& robot);
RobotModel robot_from_storable_json(const nlohmann::json& stored, const std::string& source);

// "scara", "ur10", a *.urdf file (or FILE.urdf:LINK, the chain ending at link
// LINK) or a *.json file; throws gipdyn::Error listing the options.
RobotModel load_robot(const std::string& spec);

}  // namespace gipdyn
