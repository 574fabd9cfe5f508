#pragma once
// Rigid-body inverse dynamics (KDL's recursive Newton-Euler, the reference),
// the torque regressor Phi(q, qd, qdd) of gipdyn's own, and base parameters.
#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/robot/robot_model.hpp"

namespace gipdyn {

// tau = M(q) qdd + C(q, qd) qd + g(q) by KDL::ChainIdSolver_RNE, plus
// viscous and Coulomb friction when with_friction.
Eigen::VectorXd inverse_dynamics(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                 const Eigen::VectorXd& qdd, bool with_friction = false);
// Every row of X (N x 3n: q, qd, qdd) -> N x n.
Eigen::MatrixXd inverse_dynamics(const RobotModel& robot, const Eigen::MatrixXd& X, bool with_friction = false);

// M(q) and the bias h(q, qd) = C(q, qd) qd + g(q) (plus friction when
// with_friction), by n + 2 calls of inverse_dynamics.
void mass_matrix_and_bias(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                          bool with_friction, Eigen::MatrixXd& M, Eigen::VectorXd& h);
// qdd = M(q)^-1 (tau - h(q, qd)): the accelerations the joint torques tau
// (motor and external together) produce.
Eigen::VectorXd forward_dynamics(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                 const Eigen::VectorXd& tau, bool with_friction = false);

// Phi (n x 10n, or n x 12n with friction) with Phi w = tau for
// w = [robot.inertial_parameters(); robot.friction_parameters()]. Phi depends
// only on the kinematics (and gravity), not on the robot's inertial values.
Eigen::MatrixXd regressor(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                          const Eigen::VectorXd& qdd, bool with_friction = false);
// Scratch for regressor_into, one per thread: with it the regressor of one
// state makes no heap allocation (the control-loop path of fe models).
class RegressorWorkspace {
 public:
  explicit RegressorWorkspace(const RobotModel& robot);
  ~RegressorWorkspace();
  RegressorWorkspace(RegressorWorkspace&&) noexcept;
  RegressorWorkspace& operator=(RegressorWorkspace&&) noexcept;
  struct Frames;  // per-joint transforms, twists and wrench regressors

 private:
  friend void regressor_into(const RobotModel&, const double*, const double*, const double*, bool,
                             RegressorWorkspace&, Eigen::Ref<Eigen::MatrixXd>);
  std::unique_ptr<Frames> frames_;
};
// regressor() for q, qd, qdd of robot.num_joints() entries each, into Phi
// (n x 10n, or n x 12n with friction).
void regressor_into(const RobotModel& robot, const double* q, const double* qd, const double* qdd,
                    bool with_friction, RegressorWorkspace& workspace, Eigen::Ref<Eigen::MatrixXd> Phi);
// Rows of X stacked: (N n) x p, sample-major (rows t*n .. t*n+n-1 belong to sample t).
Eigen::MatrixXd stacked_regressor(const RobotModel& robot, const Eigen::MatrixXd& X, bool with_friction = false);

// The minimal set of identifiable (base) parameters, found numerically by a
// rank-revealing (column-pivoted) QR of the regressor stacked over random
// states: Phi w = Phi[:, independent] * (w[independent] + K w[dependent]).
struct BaseParameters {
  int rank = 0;
  std::vector<Eigen::Index> independent, dependent;
  Eigen::MatrixXd K;  // rank x |dependent|
  Eigen::VectorXd from_full(const Eigen::VectorXd& w) const;
  Eigen::MatrixXd select(const Eigen::MatrixXd& Phi) const;  // Phi[:, independent]
};
BaseParameters compute_base_parameters(const RobotModel& robot, bool with_friction, int samples = 200,
                                       std::uint64_t seed = 0);

}  // namespace gipdyn
