#include "gipdyn/estimators/physics.hpp"

#include <algorithm>

#include "gipdyn/error.hpp"

namespace gipdyn {

namespace {

const std::vector<std::string>& physics_estimators() {
  static const std::vector<std::string> names{"gip", "gip-friction", "pp", "fe"};
  return names;
}

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

bool estimator_gives_physics(const std::string& name) {
  const auto& names = physics_estimators();
  return std::find(names.begin(), names.end(), name) != names.end();
}

void require_physics(const Estimator& estimator) {
  if (estimator_gives_physics(estimator.name())) return;
  std::string valid;
  for (const auto& n : physics_estimators()) valid += (valid.empty() ? "" : ", ") + n;
  throw Error("a '" + estimator.name() +
              "' model cannot give gravity, inertia or Coriolis terms: its torque is not affine in the "
              "accelerations; train one of: " + valid);
}

Eigen::MatrixXd gravity(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q) {
  require_physics(estimator);
  require_positions(estimator, Q, "positions");
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(Q.rows(), Q.cols());
  return estimator.predict(states(Q, zero, zero));
}

std::vector<Eigen::MatrixXd> inertia(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q) {
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

InertiaDiagnostics diagnose_inertia(const Eigen::MatrixXd& M) {
  InertiaDiagnostics d;
  const double scale = M.cwiseAbs().maxCoeff();
  d.asymmetry = scale > 0.0 ? (M - M.transpose()).cwiseAbs().maxCoeff() / scale : 0.0;
  const Eigen::MatrixXd S = 0.5 * (M + M.transpose());
  d.min_eigenvalue = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(S, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
  return d;
}

}  // namespace gipdyn
