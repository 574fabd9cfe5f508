#include "gipdyn/sim/trajectory.hpp"

#include <cmath>
#include <random>

#include "gipdyn/error.hpp"

namespace gipdyn {

void TrajectoryOptions::validate() const {
  if (sinusoids < 1) throw Error("trajectory: at least one sinusoid per joint is needed");
  if (!(max_angular_frequency > 0.0)) throw Error("trajectory: the maximum angular frequency must be > 0");
  if (!(position_fill > 0.0 && position_fill <= 1.0) || !(velocity_fill > 0.0 && velocity_fill <= 1.0))
    throw Error("trajectory: position and velocity fill must lie in (0, 1]");
}

SinusoidTrajectory SinusoidTrajectory::random(const RobotModel& robot, int samples, double dt, std::uint64_t seed,
                                              const TrajectoryOptions& o) {
  o.validate();
  if (samples < 1) throw Error("trajectory samples must be at least 1");
  if (!(dt > 0.0)) throw Error("trajectory sampling period dt must be positive");
  const int n = robot.num_joints(), K = o.sinusoids;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> amp(-1.0, 1.0), freq(-o.max_angular_frequency, o.max_angular_frequency),
      phase(0.0, 2.0 * M_PI);
  SinusoidTrajectory tr;
  tr.amplitude_.resize(n, K);
  tr.frequency_.resize(n, K);
  tr.phase_.resize(n, K);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < K; ++k) {
      tr.amplitude_(i, k) = amp(rng);
      tr.frequency_(i, k) = freq(rng);
      tr.phase_(i, k) = phase(rng);
    }
  tr.center_.resize(n);
  tr.scale_ = Eigen::VectorXd::Ones(n);
  for (int i = 0; i < n; ++i) tr.center_(i) = 0.5 * (robot.joint(i).limits.lower + robot.joint(i).limits.upper);
  // Largest deviation and speed of the unscaled sum on the sample grid.
  Eigen::VectorXd max_dev = Eigen::VectorXd::Zero(n), max_vel = max_dev;
  for (int s = 0; s < samples; ++s) {
    const double t = s * dt;
    const Eigen::ArrayXXd arg = tr.frequency_.array() * t + tr.phase_.array();
    const Eigen::VectorXd dev = (tr.amplitude_.array() * arg.sin()).rowwise().sum();
    const Eigen::VectorXd vel = (tr.amplitude_.array() * tr.frequency_.array() * arg.cos()).rowwise().sum();
    max_dev = max_dev.cwiseMax(dev.cwiseAbs());
    max_vel = max_vel.cwiseMax(vel.cwiseAbs());
  }
  for (int i = 0; i < n; ++i) {
    const JointLimits& l = robot.joint(i).limits;
    double s = o.position_fill * 0.5 * (l.upper - l.lower) / std::max(max_dev(i), 1e-12);
    s = std::min(s, o.velocity_fill * l.velocity / std::max(max_vel(i), 1e-12));
    tr.scale_(i) = s;
  }
  return tr;
}

void SinusoidTrajectory::evaluate(double t, Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> qd,
                                  Eigen::Ref<Eigen::VectorXd> qdd) const {
  const Eigen::ArrayXXd arg = frequency_.array() * t + phase_.array();
  const Eigen::ArrayXXd s = amplitude_.array() * arg.sin(), c = amplitude_.array() * frequency_.array() * arg.cos();
  q = center_ + scale_.cwiseProduct(s.rowwise().sum().matrix());
  qd = scale_.cwiseProduct(c.rowwise().sum().matrix());
  qdd = -scale_.cwiseProduct((s * frequency_.array().square()).rowwise().sum().matrix());
}

Eigen::MatrixXd SinusoidTrajectory::sample(int samples, double dt) const {
  const int n = num_joints();
  Eigen::MatrixXd X(samples, 3 * n);
  Eigen::VectorXd q(n), qd(n), qdd(n);
  for (int s = 0; s < samples; ++s) {
    evaluate(s * dt, q, qd, qdd);
    X.row(s) << q.transpose(), qd.transpose(), qdd.transpose();
  }
  return X;
}

}  // namespace gipdyn
