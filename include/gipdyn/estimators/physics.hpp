#pragma once
// Rigid-body terms of a learned inverse dynamics model.
//
// For the GIP family, the rigid-body regressor (fe, pp) and their prior means,
// the predicted torque is affine in the accelerations and, apart from
// friction, even in the velocities (they enter as products qd_j qd_k):
//
//   f(q, qd, qdd) = M(q) qdd + C(q, qd) qd + g(q) + friction(q, qd)
//
// with friction odd in qd. So, from torque predictions alone:
//   g(q)        = f(q, 0, 0)
//   M(q) e_j    = f(q, 0, e_j) - g(q)
//   C(q, qd) qd = (f(q, qd, 0) + f(q, -qd, 0)) / 2 - g(q)
//   friction    = (f(q, qd, 0) - f(q, -qd, 0)) / 2
// gip+friction's torque offset is even in qd and constant: it is counted in g.
// Models without that structure (rbf, the hybrids and sp, which add an RBF,
// and nn) cannot give these terms: asking is a gipdyn::Error.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/estimator.hpp"

namespace gipdyn {

// Whether a model has the structure above: Estimator::gives_rigid_body_terms().
// The names of every estimator that has it (EstimatorSpec::rigid_body_terms), in the table's order.
std::vector<std::string> physics_estimator_names();
// Throws gipdyn::Error naming the estimator and the ones that qualify, unless it does.
void require_physics(const Estimator& estimator);

// Q: rows x n joint positions. Returns rows x n gravity torques.
Eigen::MatrixXd gravity(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q);
// Which inertia matrix inertia() returns. Each joint's model learns one row of
// M, so the learned matrix is not exactly symmetric. Symmetric (the default)
// returns its symmetric part (M + M^T) / 2: the true M is symmetric, so this is
// never farther from it in Frobenius norm, and each off-diagonal entry averages
// the two joints' independent estimates. AsLearned returns the rows as the
// joints' models give them, for diagnose_inertia's asymmetry.
enum class InertiaForm { Symmetric, AsLearned };

// One n x n inertia matrix per row of Q.
std::vector<Eigen::MatrixXd> inertia(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q,
                                     InertiaForm form = InertiaForm::Symmetric);

// The velocity terms at (Q, QD), rows x n each.
struct VelocityTerms {
  Eigen::MatrixXd coriolis;  // C(q, qd) qd: centrifugal and Coriolis torques
  Eigen::MatrixXd friction;  // the part odd in qd (zero for plain GIP, pp and fe without friction)
};
VelocityTerms velocity_terms(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q,
                             const Eigen::Ref<const Eigen::MatrixXd>& QD);

// Forward dynamics of the learned model: for every row, the accelerations that
// the torques produce, qdd = M(q)^-1 (tau - f(q, qd, 0)) (f(q, qd, 0) holds
// Coriolis, gravity and friction), with M as learned (InertiaForm::AsLearned), so
// that the model's torque prediction at (q, qd, qdd) gives back qdd exactly. Throws gipdyn::Error naming the first row
// whose learned M cannot be inverted.
Eigen::MatrixXd forward_dynamics(const Estimator& estimator, const Eigen::Ref<const Eigen::MatrixXd>& Q,
                                 const Eigen::Ref<const Eigen::MatrixXd>& QD, const Eigen::Ref<const Eigen::MatrixXd>& TAU);

// A learned robot driven by torques: from (q0, qd0), one step of dt per row of
// TAU (held constant over the step by semi-implicit Euler, interpolated
// linearly to the next row by RK4). Returns rows x 3n states (q, qd, qdd),
// the first row the start, like a dataset's X.
enum class Integrator { SemiImplicitEuler, Rk4 };
Eigen::MatrixXd integrate_forward_dynamics(const Estimator& estimator, const Eigen::VectorXd& q0,
                                           const Eigen::VectorXd& qd0, const Eigen::Ref<const Eigen::MatrixXd>& TAU,
                                           double dt, Integrator integrator = Integrator::Rk4);

// How physical a learned inertia matrix is: max |M - M^T| / max |M| (zero for
// inertia()'s default symmetric form: pass the AsLearned one), and the smallest
// eigenvalue of (M + M^T) / 2 (positive for a physical M).
struct InertiaDiagnostics {
  double asymmetry = 0.0;
  double min_eigenvalue = 0.0;
};
InertiaDiagnostics diagnose_inertia(const Eigen::MatrixXd& M);

}  // namespace gipdyn
