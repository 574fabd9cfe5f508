#include "gipdyn/sim/closed_loop.hpp"

#include <cmath>
#include <string>

#include "gipdyn/error.hpp"
#include "gipdyn/robot/dynamics.hpp"

namespace gipdyn {

void TrackingOptions::validate(int joints) const {
  if (!(dt > 0.0) || !std::isfinite(dt)) throw Error("TrackingOptions::dt must be a positive number of seconds");
  if (!(bandwidth > 0.0) || !std::isfinite(bandwidth)) throw Error("TrackingOptions::bandwidth must be > 0");
  if (kp.size() != kd.size() || (kp.size() != 0 && kp.size() != joints))
    throw Error("TrackingOptions::kp and kd need one gain per joint (" + std::to_string(joints) + "), or none");
  if ((kp.array() < 0.0).any() || (kd.array() < 0.0).any() || !kp.allFinite() || !kd.allFinite())
    throw Error("TrackingOptions::kp and kd must be finite and >= 0");
}

namespace {

// The true robot's M(q) and bias h(q, qd) = C qd + g (+ friction) by RNEA.
void true_dynamics(const RobotModel& robot, const Eigen::VectorXd& q, const Eigen::VectorXd& qd, bool friction,
                   Eigen::MatrixXd& M, Eigen::VectorXd& h) {
  const int n = robot.num_joints();
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
  h = inverse_dynamics(robot, q, qd, zero, friction);
  const Eigen::VectorXd g = inverse_dynamics(robot, q, zero, zero, false);
  M.resize(n, n);
  Eigen::VectorXd e = zero;
  for (int j = 0; j < n; ++j) {
    e(j) = 1.0;
    M.col(j) = inverse_dynamics(robot, q, zero, e, false) - g;
    e(j) = 0.0;
  }
}

}  // namespace

TrackingResult track_reference(const RobotModel& robot, const Eigen::MatrixXd& reference,
                               const Eigen::MatrixXd& feedforward, const TrackingOptions& options) {
  const int n = robot.num_joints();
  options.validate(n);
  if (reference.cols() != 3 * n || reference.rows() < 2)
    throw Error("the reference needs at least 2 rows of " + std::to_string(3 * n) + " columns (q, qd, qdd)");
  if (feedforward.rows() != reference.rows() || feedforward.cols() != n)
    throw Error("the feed-forward torques need one row of " + std::to_string(n) + " per reference row");
  if (!reference.allFinite() || !feedforward.allFinite())
    throw Error("the reference or the feed-forward torques contain NaN or Inf");
  const Eigen::Index steps = reference.rows();
  Eigen::VectorXd q = reference.row(0).head(n).transpose(), qd = reference.row(0).segment(n, n).transpose();
  Eigen::MatrixXd M;
  Eigen::VectorXd h;
  TrackingResult r;
  r.kp = options.kp;
  r.kd = options.kd;
  if (r.kp.size() == 0) {
    true_dynamics(robot, q, qd, false, M, h);
    const double w = options.bandwidth;
    r.kp = w * w * M.diagonal();
    r.kd = 2.0 * w * M.diagonal();
  }
  r.q.resize(steps, n);
  r.tau.resize(steps, n);
  for (Eigen::Index k = 0; k < steps; ++k) {
    const Eigen::VectorXd q_ref = reference.row(k).head(n).transpose(), qd_ref = reference.row(k).segment(n, n).transpose();
    const Eigen::VectorXd tau = feedforward.row(k).transpose() + r.kp.cwiseProduct(q_ref - q) + r.kd.cwiseProduct(qd_ref - qd);
    r.q.row(k) = q.transpose();
    r.tau.row(k) = tau.transpose();
    true_dynamics(robot, q, qd, options.friction, M, h);
    const Eigen::VectorXd qdd = M.ldlt().solve(tau - h);
    qd += options.dt * qdd;
    q += options.dt * qd;
    if (!q.allFinite() || !qd.allFinite() || qd.cwiseAbs().maxCoeff() > 1e6)
      throw Error("the closed loop diverged at step " + std::to_string(k + 1) +
                  ": lower the gains (TrackingOptions::kp, kd) or the control period (TrackingOptions::dt)");
  }
  const Eigen::MatrixXd error = (reference.leftCols(n) - r.q).cwiseAbs();
  r.rms_error = (error.array().square().colwise().mean()).sqrt().transpose();
  r.max_error = error.colwise().maxCoeff().transpose();
  r.rms_torque = (r.tau.array().square().colwise().mean()).sqrt().transpose();
  return r;
}

}  // namespace gipdyn
