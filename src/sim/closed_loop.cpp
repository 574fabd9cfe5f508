#include "gipdyn/sim/closed_loop.hpp"

#include <cmath>
#include <random>
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
  if (!(position_noise >= 0.0) || !(velocity_noise >= 0.0) || !std::isfinite(position_noise) ||
      !std::isfinite(velocity_noise))
    throw Error("TrackingOptions::position_noise and TrackingOptions::velocity_noise must be finite standard deviations >= 0");
  if (external.size() > 0 && external.cols() != joints)
    throw Error("TrackingOptions::external needs one column per joint (" + std::to_string(joints) + "), or none");
  if (!external.allFinite()) throw Error("TrackingOptions::external contains NaN or Inf");
}

void critically_damped_gains(const RobotModel& robot, const Eigen::VectorXd& q, double bandwidth, Eigen::VectorXd& kp,
                             Eigen::VectorXd& kd) {
  Eigen::MatrixXd M;
  Eigen::VectorXd h;
  mass_matrix_and_bias(robot, q, Eigen::VectorXd::Zero(robot.num_joints()), false, M, h);
  kp = bandwidth * bandwidth * M.diagonal();
  kd = 2.0 * bandwidth * M.diagonal();
}

namespace {

void check_reference(int n, const Eigen::MatrixXd& reference, const TrackingOptions& options) {
  if (reference.cols() != 3 * n || reference.rows() < 2)
    throw Error("the reference needs at least 2 rows of " + std::to_string(3 * n) + " columns (q, qd, qdd)");
  if (!reference.allFinite()) throw Error("the reference contains NaN or Inf");
  if (options.external.size() > 0 && options.external.rows() != reference.rows())
    throw Error("TrackingOptions::external has " + std::to_string(options.external.rows()) +
                " rows, and the reference " + std::to_string(reference.rows()) + ": give one per step");
}

// Integrates the true robot under tau = law(k, q, qd) from the reference's first state.
TrackingResult run_loop(const RobotModel& robot, const Eigen::MatrixXd& reference, const TrackingOptions& options,
                        const std::function<Eigen::VectorXd(Eigen::Index, const Eigen::VectorXd&, const Eigen::VectorXd&)>& law,
                        TrackingResult r) {
  const int n = robot.num_joints();
  const Eigen::Index steps = reference.rows();
  Eigen::VectorXd q = reference.row(0).head(n).transpose(), qd = reference.row(0).segment(n, n).transpose();
  Eigen::MatrixXd M;
  Eigen::VectorXd h;
  r.q.resize(steps, n);
  r.qd.resize(steps, n);
  r.qdd.resize(steps, n);
  r.tau.resize(steps, n);
  const bool pushed = options.external.size() > 0;
  std::mt19937_64 rng(options.noise_seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const bool noisy = options.position_noise > 0.0 || options.velocity_noise > 0.0;
  Eigen::VectorXd q_seen(n), qd_seen(n);
  for (Eigen::Index k = 0; k < steps; ++k) {
    q_seen = q;
    qd_seen = qd;
    if (noisy)
      for (int i = 0; i < n; ++i) {
        q_seen(i) += options.position_noise * normal(rng);
        qd_seen(i) += options.velocity_noise * normal(rng);
      }
    const Eigen::VectorXd tau = law(k, q_seen, qd_seen);
    if (!tau.allFinite()) throw Error("the controller's torque is not finite at step " + std::to_string(k + 1));
    mass_matrix_and_bias(robot, q, qd, options.friction, M, h);
    Eigen::VectorXd force = tau - h;
    if (pushed) force += options.external.row(k).transpose();
    const Eigen::VectorXd qdd = M.ldlt().solve(force);
    r.q.row(k) = q.transpose();
    r.qd.row(k) = qd.transpose();
    r.qdd.row(k) = qdd.transpose();
    r.tau.row(k) = tau.transpose();
    qd += options.dt * qdd;
    q += options.dt * qd;
    if (!q.allFinite() || !qd.allFinite() || qd.cwiseAbs().maxCoeff() > 1e6)
      throw Error("the closed loop diverged at step " + std::to_string(k + 1) + ": lower the gains (" +
                  (options.kp.size() > 0 ? "TrackingOptions::kp and kd" : "TrackingOptions::bandwidth") +
                  ") or the control period (TrackingOptions::dt)");
  }
  const Eigen::MatrixXd error = (reference.leftCols(n) - r.q).cwiseAbs();
  r.rms_error = (error.array().square().colwise().mean()).sqrt().transpose();
  r.max_error = error.colwise().maxCoeff().transpose();
  r.rms_torque = (r.tau.array().square().colwise().mean()).sqrt().transpose();
  return r;
}

}  // namespace

TrackingResult track_reference(const RobotModel& robot, const Eigen::MatrixXd& reference,
                               const Eigen::MatrixXd& feedforward, const TrackingOptions& options) {
  const int n = robot.num_joints();
  options.validate(n);
  if (options.friction) robot.require_friction("TrackingOptions::friction");
  check_reference(n, reference, options);
  if (feedforward.rows() != reference.rows() || feedforward.cols() != n)
    throw Error("the feed-forward torques need one row of " + std::to_string(n) + " per reference row");
  if (!feedforward.allFinite()) throw Error("the feed-forward torques contain NaN or Inf");
  TrackingResult r;
  r.kp = options.kp;
  r.kd = options.kd;
  if (r.kp.size() == 0) critically_damped_gains(robot, reference.row(0).head(n).transpose(), options.bandwidth, r.kp, r.kd);
  const Eigen::VectorXd kp = r.kp, kd = r.kd;
  return run_loop(robot, reference, options,
                  [&](Eigen::Index k, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) -> Eigen::VectorXd {
                    return feedforward.row(k).transpose() +
                           kp.cwiseProduct(reference.row(k).head(n).transpose() - q) +
                           kd.cwiseProduct(reference.row(k).segment(n, n).transpose() - qd);
                  },
                  r);
}

TrackingResult track_computed_torque(const RobotModel& robot, const Eigen::MatrixXd& reference,
                                     const InverseDynamicsFunction& model, const TrackingOptions& options) {
  const int n = robot.num_joints();
  options.validate(n);
  if (options.friction) robot.require_friction("TrackingOptions::friction");
  check_reference(n, reference, options);
  if (!model) throw Error("track_computed_torque needs a model");
  const double w = options.bandwidth;
  TrackingResult r;
  r.kp = Eigen::VectorXd::Constant(n, w * w);  // in acceleration units
  r.kd = Eigen::VectorXd::Constant(n, 2.0 * w);
  Eigen::VectorXd x(3 * n);
  return run_loop(robot, reference, options,
                  [&](Eigen::Index k, const Eigen::VectorXd& q, const Eigen::VectorXd& qd) -> Eigen::VectorXd {
                    const Eigen::VectorXd e = reference.row(k).head(n).transpose() - q;
                    const Eigen::VectorXd ed = reference.row(k).segment(n, n).transpose() - qd;
                    x << q, qd, reference.row(k).tail(n).transpose() + w * w * e + 2.0 * w * ed;
                    const Eigen::VectorXd tau = model(x);
                    if (tau.size() != n) throw Error("the model gave " + std::to_string(tau.size()) + " torques for " + std::to_string(n) + " joints");
                    return tau;
                  },
                  r);
}

}  // namespace gipdyn
