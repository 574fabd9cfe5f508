#include "gipdyn/robot/robot_model.hpp"

#include <cmath>
#include <kdl/frames.hpp>
#include <kdl/rigidbodyinertia.hpp>
#include <kdl/segment.hpp>
#include <nlohmann/json.hpp>
#include <random>

#include "gipdyn/error.hpp"

namespace gipdyn {
namespace {

KDL::RigidBodyInertia to_kdl(const LinkInertial& l) {
  const Eigen::Matrix3d& I = l.inertia;
  return KDL::RigidBodyInertia(l.mass, KDL::Vector(l.com.x(), l.com.y(), l.com.z()),
                               KDL::RotationalInertia(I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)));
}

LinkInertial from_kdl(const KDL::RigidBodyInertia& I) {
  LinkInertial l;
  l.mass = I.getMass();
  const KDL::Vector c = I.getCOG();
  l.com = Eigen::Vector3d(c.x(), c.y(), c.z());
  const KDL::RotationalInertia Io = I.getRotationalInertia();  // about the frame origin
  Eigen::Matrix3d M = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(Io.data);
  // Parallel axis theorem back to the centre of mass.
  l.inertia = M - l.mass * (l.com.squaredNorm() * Eigen::Matrix3d::Identity() - l.com * l.com.transpose());
  return l;
}

bool is_prismatic(const KDL::Joint& j) {
  switch (j.getType()) {
    case KDL::Joint::TransAxis:
    case KDL::Joint::TransX:
    case KDL::Joint::TransY:
    case KDL::Joint::TransZ:
      return true;
    default:
      return false;
  }
}

}  // namespace

RobotModel RobotModel::from_dh(std::string name, std::vector<JointSpec> joints, Eigen::Vector3d gravity) {
  RobotModel r;
  r.name_ = std::move(name);
  r.joints_ = std::move(joints);
  r.gravity_ = gravity;
  for (const auto& j : r.joints_)
    if (!j.dh) throw Error("robot '" + r.name_ + "': joint '" + j.name + "' has no DH parameters");
  r.validate();
  r.build_dh_chain();
  return r;
}

RobotModel RobotModel::from_chain(std::string name, const KDL::Chain& chain, std::vector<JointSpec> joints,
                                  Eigen::Vector3d gravity) {
  RobotModel r;
  r.name_ = std::move(name);
  r.gravity_ = gravity;
  if (static_cast<int>(chain.getNrOfSegments()) != static_cast<int>(joints.size()) ||
      chain.getNrOfJoints() != chain.getNrOfSegments())
    throw Error("robot '" + r.name_ + "': the chain must have one movable segment per joint");
  for (unsigned s = 0; s < chain.getNrOfSegments(); ++s) {
    const KDL::Segment& seg = chain.getSegment(s);
    JointSpec& spec = joints[s];
    spec.type = is_prismatic(seg.getJoint()) ? JointType::Prismatic : JointType::Revolute;
    spec.link = from_kdl(seg.getInertia());
    spec.dh.reset();
  }
  r.joints_ = std::move(joints);
  r.chain_ = chain;
  r.validate();
  return r;
}

void RobotModel::validate() const {
  if (joints_.empty() || num_joints() > JointTypes::kMaxJoints)
    throw Error("robot '" + name_ + "' must have 1 to " + std::to_string(JointTypes::kMaxJoints) + " joints");
  for (int i = 0; i < num_joints(); ++i) {
    const JointSpec& j = joints_[static_cast<size_t>(i)];
    const std::string where = "robot '" + name_ + "', joint " + std::to_string(i + 1) + " ('" + j.name + "')";
    const LinkInertial& l = j.link;
    if (!std::isfinite(l.mass) || !l.com.allFinite() || !l.inertia.allFinite())
      throw Error(where + ": mass, centre of mass or inertia is not finite");
    // URDF links without <inertial> (frames between two joints) are massless;
    // a link given a mass but no inertia is a point mass. Both are physical.
    const bool massless = l.mass == 0.0 && l.inertia.isZero(0.0);
    if (!massless && !(l.mass > 0.0))
      throw Error(where + ": mass " + std::to_string(l.mass) +
                  " kg must be positive (or the link massless: mass 0 and a zero inertia tensor)");
    if ((l.inertia - l.inertia.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + l.inertia.cwiseAbs().maxCoeff()))
      throw Error(where + ": inertia tensor is not symmetric");
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(l.inertia).eigenvalues();
    if (ev.minCoeff() < -1e-12 * (1.0 + ev.cwiseAbs().maxCoeff()))
      throw Error(where + ": inertia tensor is not positive semidefinite (eigenvalues " + std::to_string(ev(0)) +
                  ", " + std::to_string(ev(1)) + ", " + std::to_string(ev(2)) +
                  "); check the units (kg m^2) and signs");
    if (ev(0) + ev(1) < ev(2) * (1 - 1e-9))
      throw Error(where + ": principal moments " + std::to_string(ev(0)) + ", " + std::to_string(ev(1)) + ", " +
                  std::to_string(ev(2)) + " kg m^2 violate the triangle inequality (the largest must not exceed the "
                  "sum of the other two): not a physical rigid body; check the inertia, or raise the smaller moments");
    if (!(j.limits.lower < j.limits.upper)) throw Error(where + ": lower position limit must be below the upper one");
    if (!(j.limits.velocity > 0.0)) throw Error(where + ": velocity limit must be positive");
    if (j.friction.viscous < 0.0 || j.friction.coulomb < 0.0) throw Error(where + ": friction must be >= 0");
    if (j.dh && !(std::isfinite(j.dh->a) && std::isfinite(j.dh->alpha) && std::isfinite(j.dh->d) &&
                  std::isfinite(j.dh->theta)))
      throw Error(where + ": DH parameters must be finite");
  }
  // A joint that moves nothing has no torque whatever it does: nothing to
  // learn, and a singular inertia matrix to simulate. Every joint moves the
  // last link, so only the last joint can move nothing.
  const JointSpec& last = joints_.back();
  if (last.link.mass == 0.0 && last.link.inertia.isZero(0.0))
    throw Error("robot '" + name_ + "', joint " + std::to_string(num_joints()) + " ('" + last.name +
                "') moves no mass: its link and every link after it are massless; give them their masses "
                "(URDF: <inertial>), or end the chain before that joint");
  if (!gravity_.allFinite()) throw Error("robot '" + name_ + "': gravity must be finite");
}

void RobotModel::build_dh_chain() {
  chain_ = KDL::Chain();
  for (const JointSpec& j : joints_) {
    const KDL::Joint joint(j.name, j.type == JointType::Revolute ? KDL::Joint::RotZ : KDL::Joint::TransZ);
    chain_.addSegment(KDL::Segment(j.name, joint, KDL::Frame::DH(j.dh->a, j.dh->alpha, j.dh->d, j.dh->theta),
                                   to_kdl(j.link)));
  }
}

JointTypes RobotModel::joint_types() const {
  std::string s;
  for (const auto& j : joints_) s.push_back(j.type == JointType::Revolute ? 'R' : 'P');
  return JointTypes::parse(s);
}

Eigen::VectorXd RobotModel::inertial_parameters() const {
  Eigen::VectorXd w(10 * num_joints());
  for (int i = 0; i < num_joints(); ++i) {
    const LinkInertial& l = joints_[static_cast<size_t>(i)].link;
    const Eigen::Vector3d h = l.mass * l.com;
    const Eigen::Matrix3d Io =
        l.inertia + l.mass * (l.com.squaredNorm() * Eigen::Matrix3d::Identity() - l.com * l.com.transpose());
    w.segment<10>(10 * i) << l.mass, h(0), h(1), h(2), Io(0, 0), Io(0, 1), Io(0, 2), Io(1, 1), Io(1, 2), Io(2, 2);
  }
  return w;
}

Eigen::VectorXd RobotModel::friction_parameters() const {
  Eigen::VectorXd f(2 * num_joints());
  for (int i = 0; i < num_joints(); ++i) {
    f(i) = joints_[static_cast<size_t>(i)].friction.viscous;
    f(num_joints() + i) = joints_[static_cast<size_t>(i)].friction.coulomb;
  }
  return f;
}

void RobotModel::require_friction(const std::string& field) const {
  if (!friction_parameters().isZero(0.0)) return;
  throw Error(field + " asks for friction, but robot '" + name_ +
              "' has none (every joint's viscous and Coulomb coefficients are 0): give them in its description "
              "(docs/robot-format.md) or leave friction off");
}

RobotModel RobotModel::with_gravity(const Eigen::Vector3d& g) const {
  RobotModel r = *this;
  r.gravity_ = g;
  return r;
}

RobotModel RobotModel::with_perturbed_kinematics(std::uint64_t seed, double length, double angle,
                                                 nlohmann::json* drawn) const {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ul(-length, length), ua(-angle, angle);
  RobotModel r = *this;
  r.urdf_.clear();  // the perturbed chain no longer matches the text
  r.urdf_tip_.clear();
  nlohmann::json record = nlohmann::json::array();
  if (is_dh()) {
    for (JointSpec& j : r.joints_) {
      const double da = ul(rng), dd = ul(rng), dalpha = ua(rng), dtheta = ua(rng);
      j.dh->a += da;
      j.dh->d += dd;
      j.dh->alpha += dalpha;
      j.dh->theta += dtheta;
      record.push_back({{"joint", j.name}, {"da", da}, {"dd", dd}, {"dalpha", dalpha}, {"dtheta", dtheta}});
    }
    r.build_dh_chain();
  } else {
    KDL::Chain chain;
    for (unsigned s = 0; s < chain_.getNrOfSegments(); ++s) {
      const KDL::Segment& seg = chain_.getSegment(s);
      const double dx = ul(rng), dy = ul(rng), dz = ul(rng), dr = ua(rng), dp = ua(rng), dyaw = ua(rng);
      // Perturb the fixed part of the segment (joint frame to tip); the joint pose at q = 0 is identity.
      const KDL::Frame delta(KDL::Rotation::RPY(dr, dp, dyaw), KDL::Vector(dx, dy, dz));
      chain.addSegment(KDL::Segment(seg.getName(), seg.getJoint(), seg.getFrameToTip() * delta,
                                    seg.getInertia()));  // the link moves with its frame, as in the DH case
      record.push_back({{"joint", seg.getName()}, {"dxyz", {dx, dy, dz}}, {"drpy", {dr, dp, dyaw}}});
    }
    r.chain_ = chain;
  }
  if (drawn) *drawn = record;
  return r;
}

nlohmann::json RobotModel::to_json() const {
  nlohmann::json out;
  out["name"] = name_;
  out["gravity"] = {gravity_.x(), gravity_.y(), gravity_.z()};
  nlohmann::json joints = nlohmann::json::array();
  for (const JointSpec& j : joints_) {
    nlohmann::json e;
    e["name"] = j.name;
    e["type"] = j.type == JointType::Revolute ? "R" : "P";
    if (j.dh) e["dh"] = {{"a", j.dh->a}, {"alpha", j.dh->alpha}, {"d", j.dh->d}, {"theta", j.dh->theta}};
    e["mass"] = j.link.mass;
    e["com"] = {j.link.com.x(), j.link.com.y(), j.link.com.z()};
    nlohmann::json I = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) I.push_back({j.link.inertia(r, 0), j.link.inertia(r, 1), j.link.inertia(r, 2)});
    e["inertia"] = I;
    e["limits"] = {{"lower", j.limits.lower}, {"upper", j.limits.upper}, {"velocity", j.limits.velocity}};
    e["friction"] = {{"viscous", j.friction.viscous}, {"coulomb", j.friction.coulomb}};
    joints.push_back(e);
  }
  out["joints"] = joints;
  return out;
}

}  // namespace gipdyn
