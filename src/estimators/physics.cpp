#include "gipdyn/estimators/physics.hpp"

#include <algorithm>
#include <cmath>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"

namespace gipdyn {

namespace {

void require_positions(const Estimator& e, const Eigen::Ref<const Eigen::MatrixXd>& Q, const char* what) {
  const int n = e.joints().size();
  if (Q.cols() != n)
    throw Error(std::string(what) + " have " + std::to_string(Q.cols()) + " columns; this " + e.joints().str() +
                " model needs " + std::to_string(n));
  if (!Q.allFinite()) throw Error(std::string(what) + " contain NaN or Inf");
}

// Rows (q, qd, qdd) for the model.
Eigen::MatrixXd states(const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::MatrixXd& QD, const Eigen::MatrixXd& QDD) {
  Eigen::MatrixXd X(Q.rows(), 3 * Q.cols());
  X << Q, QD, QDD;
  return X;
}

}  // namespace

std::vector<std::string> physics_estimator_names() {
  return estimator_names_where([](const EstimatorSpec& e) { return e.rigid_body_terms; });
}

void require_physics(const Estimator& estimator) {
  if (estimator.gives_rigid_body_terms()) return;
  throw Error("a '" + estimator.name() + "' model cannot give gravity, inertia or Coriolis terms: " +
              estimator.why_no_rigid_body_terms() + "; train one of: " + joined(physics_estimator_names()));
}

Eigen::MatrixXd gravity(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q) {
  require_physics(estimator);
  require_positions(estimator, Q, "positions");
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(Q.rows(), Q.cols());
  return estimator.predict(states(Q, zero, zero));
}

std::vector<Eigen::MatrixXd> inertia(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q,
                                     InertiaForm form) {
  require_physics(estimator);
  require_positions(estimator, Q, "positions");
  const Eigen::Index rows = Q.rows();
  const int n = estimator.joints().size();
  // One batch: for every row, the state with qdd = 0 and the n states with qdd = e_j.
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(rows * (n + 1), 3 * n);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (int j = 0; j <= n; ++j) {
      const Eigen::Index k = r * (n + 1) + j;
      X.row(k).head(n) = Q.row(r);
      if (j > 0) X(k, 2 * n + j - 1) = 1.0;
    }
  const Eigen::MatrixXd tau = estimator.predict(X);
  std::vector<Eigen::MatrixXd> out;
  out.reserve(static_cast<size_t>(rows));
  for (Eigen::Index r = 0; r < rows; ++r) {
    Eigen::MatrixXd M(n, n);
    const Eigen::RowVectorXd g = tau.row(r * (n + 1));
    for (int j = 0; j < n; ++j) M.col(j) = (tau.row(r * (n + 1) + 1 + j) - g).transpose();
    if (form == InertiaForm::Symmetric) M = (0.5 * (M + M.transpose())).eval();
    out.push_back(M);
  }
  return out;
}

VelocityTerms velocity_terms(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q,
                             const Eigen::Ref<const Eigen::MatrixXd>& QD) {
  require_physics(estimator);
  require_positions(estimator, Q, "positions");
  require_positions(estimator, QD, "velocities");
  if (QD.rows() != Q.rows())
    throw Error("positions and velocities have " + std::to_string(Q.rows()) + " and " + std::to_string(QD.rows()) +
                " rows; give one velocity per position");
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(Q.rows(), Q.cols());
  const Eigen::MatrixXd forward = estimator.predict(states(Q, QD, zero));
  const Eigen::MatrixXd backward = estimator.predict(states(Q, -QD, zero));
  const Eigen::MatrixXd g = estimator.predict(states(Q, zero, zero));
  VelocityTerms t;
  t.coriolis = 0.5 * (forward + backward) - g;
  t.friction = 0.5 * (forward - backward);
  return t;
}

Eigen::MatrixXd forward_dynamics(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q,
                                 const Eigen::Ref<const Eigen::MatrixXd>& QD, const Eigen::Ref<const Eigen::MatrixXd>& TAU) {
  require_physics(estimator);
  require_positions(estimator, Q, "positions");
  require_positions(estimator, QD, "velocities");
  require_positions(estimator, TAU, "torques");
  if (QD.rows() != Q.rows() || TAU.rows() != Q.rows())
    throw Error("positions, velocities and torques have " + std::to_string(Q.rows()) + ", " +
                std::to_string(QD.rows()) + " and " + std::to_string(TAU.rows()) + " rows; give one of each per state");
  const Eigen::MatrixXd bias = estimator.predict(states(Q, QD, Eigen::MatrixXd::Zero(Q.rows(), Q.cols())));
  // The rows as learned, so that the accelerations reproduce the model's own torque predictions.
  const std::vector<Eigen::MatrixXd> Ms = inertia(estimator, Q, InertiaForm::AsLearned);
  Eigen::MatrixXd QDD(Q.rows(), Q.cols());
  for (Eigen::Index r = 0; r < Q.rows(); ++r) {
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(Ms[static_cast<size_t>(r)]);
    if (!lu.isInvertible())
      throw Error("the learned inertia matrix at row " + std::to_string(r + 1) +
                  " is singular: the model cannot give accelerations there (diagnose it with inertia())");
    QDD.row(r) = lu.solve((TAU.row(r) - bias.row(r)).transpose()).transpose();
  }
  return QDD;
}

Eigen::MatrixXd integrate_forward_dynamics(const Estimator& estimator, const Eigen::VectorXd& q0,
                                           const Eigen::VectorXd& qd0, const Eigen::Ref<const Eigen::MatrixXd>& TAU,
                                           double dt, Integrator integrator) {
  const int n = estimator.joints().size();
  if (q0.size() != n || qd0.size() != n)
    throw Error("q0 and qd0 need " + std::to_string(n) + " entries for this " + estimator.joints().str() + " model");
  if (!(dt > 0.0) || !std::isfinite(dt)) throw Error("dt must be a positive, finite step in seconds");
  const Eigen::Index steps = TAU.rows();
  Eigen::Index step = 0;
  auto accel = [&](const Eigen::VectorXd& q, const Eigen::VectorXd& qd, const Eigen::VectorXd& tau) {
    // No robot joint moves at 10^6 rad/s or m/s: beyond that the integration has
    // diverged, and soon the inertia matrix would be lost to cancellation.
    if (!q.allFinite() || !qd.allFinite() || qd.cwiseAbs().maxCoeff() > 1e6)
      throw Error("the learned robot diverged at step " + std::to_string(step + 1) + " (t = " +
                  std::to_string(static_cast<double>(step) * dt) +
                  " s): its accelerations grew without bound, so its inertia matrix is not physical along this "
                  "motion (check M with the physics functions, or train on more varied motion)");
    return forward_dynamics(estimator, q.transpose(), qd.transpose(), tau.transpose()).row(0).transpose().eval();
  };
  Eigen::MatrixXd out(steps, 3 * n);
  Eigen::VectorXd q = q0, qd = qd0;
  for (Eigen::Index k = 0; k < steps; ++k) {
    step = k;
    const Eigen::VectorXd tau = TAU.row(k).transpose();
    const Eigen::VectorXd qdd = accel(q, qd, tau);
    out.row(k) << q.transpose(), qd.transpose(), qdd.transpose();
    if (!qdd.allFinite())
      throw Error("the learned robot's accelerations are not finite at step " + std::to_string(k + 1));
    if (k + 1 == steps) break;
    if (integrator == Integrator::SemiImplicitEuler) {
      qd += dt * qdd;
      q += dt * qd;
      continue;
    }
    // RK4 on (q, qd) with the torque interpolated linearly between this row and the next.
    const Eigen::VectorXd tau_next = TAU.row(k + 1).transpose(), tau_mid = 0.5 * (tau + tau_next);
    const Eigen::VectorXd k1q = qd, k1v = qdd;
    const Eigen::VectorXd k2q = qd + 0.5 * dt * k1v, k2v = accel(q + 0.5 * dt * k1q, k2q, tau_mid);
    const Eigen::VectorXd k3q = qd + 0.5 * dt * k2v, k3v = accel(q + 0.5 * dt * k2q, k3q, tau_mid);
    const Eigen::VectorXd k4q = qd + dt * k3v, k4v = accel(q + dt * k3q, k4q, tau_next);
    q += dt / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
    qd += dt / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
  }
  return out;
}

InertiaDiagnostics diagnose_inertia(const Eigen::MatrixXd& M) {
  InertiaDiagnostics d;
  const double scale = M.cwiseAbs().maxCoeff();
  d.asymmetry = scale > 0.0 ? (M - M.transpose()).cwiseAbs().maxCoeff() / scale : 0.0;
  const Eigen::MatrixXd S = 0.5 * (M + M.transpose());
  d.min_eigenvalue = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(S, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
  return d;
}

}  // namespace gipdyn
