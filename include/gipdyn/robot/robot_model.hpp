#pragma once
// A serial robot: a chain of revolute/prismatic joints (a KDL chain), each
// link's inertial parameters, joint limits, optional friction and gravity.
// Built from standard DH parameters (built-in models, JSON descriptions) or
// from a URDF file (robot_loader.hpp).
#include <Eigen/Dense>
#include <cstdint>
#include <kdl/chain.hpp>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn {

// Standard DH: T = Rz(theta + q) Tz(d) Tx(a) Rx(alpha) for a revolute joint,
// Rz(theta) Tz(d + q) Tx(a) Rx(alpha) for a prismatic one. Metres and radians.
struct DhParameters {
  double a = 0.0, alpha = 0.0, d = 0.0, theta = 0.0;
};

// Mass (kg), centre of mass (m) and inertia tensor about the centre of mass (kg m^2),
// both in the link frame (the frame at the tip of the joint's segment; for DH, frame i).
struct LinkInertial {
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
};

struct JointLimits {
  double lower = -M_PI, upper = M_PI;  // rad or m
  double velocity = 2.0;               // rad/s or m/s
};

struct JointFriction {
  double viscous = 0.0;  // N m s/rad (N s/m)
  double coulomb = 0.0;  // N m (N)
};

struct JointSpec {
  std::string name;
  JointType type = JointType::Revolute;
  std::optional<DhParameters> dh;  // set for DH robots
  LinkInertial link;
  JointLimits limits;
  JointFriction friction;
};

class RobotModel {
 public:
  // A DH robot: every joint has dh set. Validates (throws gipdyn::Error).
  static RobotModel from_dh(std::string name, std::vector<JointSpec> joints,
                            Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.81));
  // A robot from a KDL chain of movable segments (one per joint, inertia in
  // the segments). joints supply names, limits and friction.
  static RobotModel from_chain(std::string name, const KDL::Chain& chain, std::vector<JointSpec> joints,
                               Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.81));

  const std::string& name() const { return name_; }
  int num_joints() const { return static_cast<int>(joints_.size()); }
  JointTypes joint_types() const;
  const JointSpec& joint(int i) const { return joints_[static_cast<size_t>(i)]; }
  const std::vector<JointSpec>& joints() const { return joints_; }
  const KDL::Chain& chain() const { return chain_; }
  const Eigen::Vector3d& gravity() const { return gravity_; }
  bool is_dh() const { return !joints_.empty() && joints_.front().dh.has_value(); }

  // The 10 standard inertial parameters of every link, docs/method.md section 6:
  // (m, m cx, m cy, m cz, Ixx, Ixy, Ixz, Iyy, Iyz, Izz) with I about the link frame origin.
  Eigen::VectorXd inertial_parameters() const;
  // (viscous_1..n, coulomb_1..n).
  Eigen::VectorXd friction_parameters() const;
  // Throws gipdyn::Error naming `field` when no joint has a viscous or Coulomb
  // coefficient: asking such a robot for friction would silently add none.
  void require_friction(const std::string& field) const;

  RobotModel with_gravity(const Eigen::Vector3d& g) const;

  // The same robot with its kinematics perturbed uniformly: lengths by up to
  // `length` metres, angles by up to `angle` radians (DH: a, d, alpha, theta;
  // URDF: every joint origin's xyz and rpy). What was drawn is written to `drawn`.
  RobotModel with_perturbed_kinematics(std::uint64_t seed, double length, double angle, nlohmann::json* drawn) const;

  // A JSON description of a DH robot in the format load_robot_json reads.
  nlohmann::json to_json() const;

  // The URDF text a robot was loaded from (empty for DH robots and perturbed
  // copies) and the chain's last link when one was named, kept so that model
  // files can rebuild the same chain.
  const std::string& urdf() const { return urdf_; }
  const std::string& urdf_tip() const { return urdf_tip_; }
  void set_urdf(std::string xml, std::string tip_link = "") {
    urdf_ = std::move(xml);
    urdf_tip_ = std::move(tip_link);
  }

 private:
  void build_dh_chain();
  void validate() const;

  std::string name_;
  std::vector<JointSpec> joints_;
  KDL::Chain chain_;
  Eigen::Vector3d gravity_ = Eigen::Vector3d(0, 0, -9.81);
  std::string urdf_, urdf_tip_;
};

}  // namespace gipdyn
