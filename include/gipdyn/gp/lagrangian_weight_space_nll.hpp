#pragma once
// LIP's marginal likelihood in weight space (estimators/lagrangian_estimator.hpp).
//
// Every factor of the Lagrangian kernel is a sum of products of monomials with
// one weight each (LagrangianKernel::kinetic_monomial_weights), so the torque
// covariance is a finite feature expansion with a diagonal prior,
//
//   K = Phi diag(s) Phi^T,   s_f = lambda_ab prod_m w_m,k_m(f)   (kinetic),
//                            s_f = prod_m w_m,k_m(f)             (potential),
//                            s_f = friction variance              (friction),
//
// one feature per pair (a, b) and product of one monomial per joint (1, cos,
// sin, cos^2, sin^2, cos sin of a revolute joint's kinetic factors, 1, q, q^2
// of a prismatic one's; 1, cos, sin or 1, q of the potential's), and four per
// joint with friction. The features of the energies do not depend on the
// hyperparameters, only their prior variances do; friction's depend on its
// two velocities. With D the noise variances on the diagonal and
// A = I + S^1/2 Phi^T D^-1 Phi S^1/2 (r x r for r features):
//
//   y^T (K + D)^-1 y = |D^-1/2 (y - Phi S^1/2 m)|^2 + |m|^2,  m = A^-1 S^1/2 Phi^T D^-1 y,
//   log |K + D|      = sum log D + log |A|,
//
// so one evaluation costs O(r^3) plus O(N n r) instead of the (N n)^3 and the
// O(N^2 n^3) gradient contraction of kernel space, and equals it up to
// rounding. r depends on the joints alone (569 for a SCARA's serial chain with
// friction, tens of thousands for a 6R arm): worthwhile() says when it pays.
#include <Eigen/Dense>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/kernels/lagrangian_kernel.hpp"

namespace gipdyn {

class LagrangianWeightSpaceNll {
 public:
  // Features of this kernel's torques (energies, and friction where it has it).
  static double feature_count(const LagrangianKernel& kernel);
  // Whether an evaluation on `rows` states costs less here than in kernel
  // space: fewer features than torques (rows x joints), and few enough that
  // the per-joint r x r products fit in memory comfortably.
  static bool worthwhile(const LagrangianKernel& kernel, Eigen::Index rows);
  // Bytes a likelihood on `rows` states holds (its features and their
  // products), and bytes one evaluation adds while it runs.
  static double bytes(const LagrangianKernel& kernel, Eigen::Index rows);
  static double evaluation_bytes(const LagrangianKernel& kernel, Eigen::Index rows);

  // kernel: its joints, serial chain and friction fix the features (its
  // parameters are read by evaluate). X: the N x 3n states; y: their N n
  // torques, sample-major (entry r n + i is joint i's torque at state r).
  LagrangianWeightSpaceNll(const LagrangianKernel& kernel, const Eigen::MatrixXd& X, const Eigen::VectorXd& y);

  // The NLL of y under cov = K + diag(noise per joint) and, with_gradient, its
  // gradient with respect to (kernel log-parameters, log noise variance per
  // joint), the order of LIP's search. alpha (optional): (K + noise)^-1 y,
  // sample-major, the kernel-space weights of the posterior mean. The kernel
  // must have the structure of the one given to the constructor.
  // NotPositiveDefinite where A is too ill-conditioned for its rounding (a
  // noise variance far below the kernel's scale): evaluate in kernel space,
  // whose jitter handles it.
  NllEvaluation evaluate(const LagrangianKernel& kernel, const Eigen::VectorXd& noise, bool with_gradient,
                         Eigen::VectorXd* alpha = nullptr) const;

  Eigen::Index features() const { return energy_features_ + friction_features_; }

 private:
  // The kinetic energy's features come in terms (one per joint on a serial
  // chain, one otherwise): a term's pairs (a, b) times the products of one
  // monomial per joint of `joints`, the first varying fastest.
  struct Term {
    std::vector<int> joints;
    std::vector<int> pair_params;  // index of lambda_ab in the log-parameters, per pair of the term
    std::vector<std::pair<int, int>> pairs;
    Eigen::MatrixXi monomials;     // products x joints.size(): each product's monomial per joint
    Eigen::Index column = 0;       // first feature; pair p's products follow at column + p * products
  };

  void check_structure(const LagrangianKernel& kernel) const;

  int n_ = 0;
  Eigen::Index rows_ = 0;
  bool serial_chain_ = false, friction_ = false;
  std::vector<bool> revolute_;
  std::vector<Term> terms_;
  Eigen::MatrixXi potential_monomials_;  // products x n
  Eigen::Index potential_column_ = 0, energy_features_ = 0, friction_features_ = 0;
  Eigen::MatrixXd velocities_;           // N x n: friction's features are functions of each joint's velocity
  std::vector<Eigen::MatrixXd> phi_;     // per joint i: energy features x N, the features of tau_i at each state
  std::vector<Eigen::MatrixXd> gram_;    // per joint: phi_ phi_^T
  std::vector<Eigen::VectorXd> y_;       // per joint: its N torques
  std::vector<Eigen::VectorXd> phi_y_;   // per joint: phi_ y_
};

}  // namespace gipdyn
