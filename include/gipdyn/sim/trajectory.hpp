#pragma once
// The paper's excitation trajectories: every joint follows
//   q_i(t) = c_i + s_i sum_{k=1..K} A_ik sin(w_ik t + phi_ik),
// K = 200 sinusoids, amplitudes A uniform in [-1, 1], angular frequencies w
// uniform in [-2, 2] rad/s, phases uniform in [0, 2 pi). qd and qdd are the
// analytic derivatives. c_i is the middle of the joint's range and s_i is the
// largest scale that keeps the sampled positions within position_fill of the
// half range and the velocities within velocity_fill of the velocity limit.
#include <Eigen/Dense>
#include <cstdint>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/robot/robot_model.hpp"

namespace gipdyn {

struct TrajectoryOptions {
  int sinusoids = 200;
  double max_angular_frequency = 2.0;  // rad/s
  double position_fill = 0.9;
  double velocity_fill = 0.9;
  void validate() const;  // throws gipdyn::Error
};

class SinusoidTrajectory {
 public:
  // A random trajectory, scaled on the sample grid t = 0, dt, ..., (samples - 1) dt.
  static SinusoidTrajectory random(const RobotModel& robot, int samples, double dt, std::uint64_t seed,
                                   const TrajectoryOptions& options = {});

  int num_joints() const { return static_cast<int>(center_.size()); }
  void evaluate(double t, Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> qd,
                Eigen::Ref<Eigen::VectorXd> qdd) const;
  // samples x 3n: (q, qd, qdd) at t = k dt.
  Eigen::MatrixXd sample(int samples, double dt) const;

 private:
  Eigen::VectorXd center_, scale_;
  Eigen::MatrixXd amplitude_, frequency_, phase_;  // n x K
};

}  // namespace gipdyn
