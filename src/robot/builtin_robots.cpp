// The built-in robot models. Every number is here, with where it comes from.
#include <cmath>

#include "gipdyn/robot/robot_loader.hpp"

namespace gipdyn {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Inertia about the centre of mass of a solid cylinder of mass m, radius r and
// length h whose axis is the given link-frame axis (0 = x, 1 = y, 2 = z).
Eigen::Matrix3d cylinder(double m, double r, double h, int axis) {
  const double along = 0.5 * m * r * r, across = m * (3 * r * r + h * h) / 12.0;
  Eigen::Vector3d d = Eigen::Vector3d::Constant(across);
  d(axis) = along;
  return d.asDiagonal();
}

JointSpec joint(const std::string& name, JointType type, DhParameters dh, double mass, Eigen::Vector3d com,
                Eigen::Matrix3d inertia, JointLimits limits, JointFriction friction) {
  JointSpec j;
  j.name = name;
  j.type = type;
  j.dh = dh;
  j.link = {mass, com, inertia};
  j.limits = limits;
  j.friction = friction;
  return j;
}

}  // namespace

// Adept One-like SCARA (joints R, R, P, R; joint 3 prismatic, moving down).
// Geometry: Adept One nominal link lengths 425 mm and 375 mm, column height 877 mm,
// quill stroke 195 mm, joint ranges +-150, +-147 and +-270 deg (Adept One robot
// specifications, as used in Spong & Vidyasagar's SCARA example).
// Masses and inertias are NOT manufacturer data: plausible values chosen for this
// project (links as solid cylinders), with joints 3+4 carrying 3.5 kg so that the
// prismatic joint holds about 34 N against gravity (docs/method.md section 5).
// Friction (used only with --friction): plausible harmonic-drive values.
RobotModel scara_robot() {
  const auto R = JointType::Revolute, P = JointType::Prismatic;
  std::vector<JointSpec> j;
  j.push_back(joint("joint1", R, {0.425, 0.0, 0.877, 0.0}, 13.0, {-0.2125, 0.0, 0.0}, cylinder(13.0, 0.06, 0.425, 0),
                    {-150 * kDeg, 150 * kDeg, 3.5}, {1.0, 1.5}));
  j.push_back(joint("joint2", R, {0.375, M_PI, 0.0, 0.0}, 8.0, {-0.1875, 0.0, 0.0}, cylinder(8.0, 0.05, 0.375, 0),
                    {-147 * kDeg, 147 * kDeg, 6.0}, {0.8, 1.0}));
  j.push_back(joint("joint3", P, {0.0, 0.0, 0.0, 0.0}, 2.5, {0.0, 0.0, -0.15}, cylinder(2.5, 0.015, 0.30, 2),
                    {0.0, 0.195, 1.0}, {5.0, 3.0}));
  j.push_back(joint("joint4", R, {0.0, 0.0, 0.2, 0.0}, 1.0, {0.02, 0.01, -0.10}, cylinder(1.0, 0.04, 0.10, 2),
                    {-270 * kDeg, 270 * kDeg, 7.0}, {0.05, 0.1}));
  return RobotModel::from_dh("scara", j);
}

// Universal Robots UR10 (CB3), 6R.
// DH and masses: Universal Robots, "Parameters for calculations of kinematics and
// dynamics" (UR10: d1 0.1273, a2 -0.612, a3 -0.5723, d4 0.163941, d5 0.1157,
// d6 0.0922 m; alpha 90, 0, 0, 90, -90, 0 deg; masses 7.1, 12.7, 4.27, 2.0, 2.0,
// 0.365 kg; centres of mass as listed there, in the DH frames).
// Inertias are NOT published by UR: solid cylinders with the link's length along
// the link axis (radii 75, 75, 60, 60, 60, 45 mm) — plausible, not measured.
// Limits: +-360 deg; 120 deg/s for joints 1-2, 180 deg/s for joints 3-6 (UR10 manual).
// Friction (only with --friction): plausible values, not identified.
RobotModel ur10_robot() {
  const auto R = JointType::Revolute;
  const double v12 = 120 * kDeg, v36 = 180 * kDeg, lim = 2 * M_PI;
  std::vector<JointSpec> j;
  j.push_back(joint("shoulder_pan", R, {0.0, M_PI / 2, 0.1273, 0.0}, 7.1, {0.021, 0.0, 0.027},
                    cylinder(7.1, 0.075, 0.15, 2), {-lim, lim, v12}, {8.0, 10.0}));
  j.push_back(joint("shoulder_lift", R, {-0.612, 0.0, 0.0, 0.0}, 12.7, {0.38, 0.0, 0.158},
                    cylinder(12.7, 0.075, 0.612, 0), {-lim, lim, v12}, {8.0, 10.0}));
  j.push_back(joint("elbow", R, {-0.5723, 0.0, 0.0, 0.0}, 4.27, {0.24, 0.0, 0.068}, cylinder(4.27, 0.06, 0.5723, 0),
                    {-lim, lim, v36}, {5.0, 6.0}));
  j.push_back(joint("wrist1", R, {0.0, M_PI / 2, 0.163941, 0.0}, 2.0, {0.0, 0.007, 0.018},
                    cylinder(2.0, 0.06, 0.12, 2), {-lim, lim, v36}, {2.0, 2.0}));
  j.push_back(joint("wrist2", R, {0.0, -M_PI / 2, 0.1157, 0.0}, 2.0, {0.0, 0.007, 0.018},
                    cylinder(2.0, 0.06, 0.12, 2), {-lim, lim, v36}, {2.0, 2.0}));
  j.push_back(joint("wrist3", R, {0.0, 0.0, 0.0922, 0.0}, 0.365, {0.0, 0.0, -0.026}, cylinder(0.365, 0.045, 0.04, 2),
                    {-lim, lim, v36}, {1.0, 1.0}));
  return RobotModel::from_dh("ur10", j);
}

const std::vector<std::string>& builtin_robot_names() {
  static const std::vector<std::string> names{"scara", "ur10"};
  return names;
}

}  // namespace gipdyn
