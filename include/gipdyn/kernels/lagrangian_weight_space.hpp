#pragma once
// The posterior mean of a LIP model (estimators/lagrangian_estimator.hpp) in
// weight space, for fast queries.
//
// Every factor of the Lagrangian kernel is a finite sum of monomials in
// (cos q, sin q) or q (LagrangianKernel::kinetic_monomial_weights), so each
// kinetic coefficient h_ab(q) and the potential V(q) are sums of products of
// one basis function per joint (1, cos q, sin q, cos 2q, sin 2q for a revolute
// joint's kinetic factors, 1, q, q^2 for a prismatic one's; 1, cos q, sin q or
// 1, q for the potential's), with finitely many weights, and the torque is
// linear in them:
//
//   tau_i = sum_{a<=b} (d_ai qdd_b + d_bi qdd_a) h_ab + (d_ai qd_b + d_bi qd_a) dh_ab/dt
//           - qd_a qd_b dh_ab/dq_i + dV/dq_i  (+ friction_i(qd_i)).
//
// The posterior mean of those weights, cov(weights, tau(X)) alpha, is computed
// once (O(N F n^2)); a query then contracts them with the basis at q, joint by
// joint, for each h_ab and its gradient, in O(F n^2) with F products per
// coefficient (the product over joints of 5 for a revolute joint, 3 for a
// prismatic one: 375 for a SCARA, 15625 for a 6R arm), instead of one n x n
// kernel block per training row. F grows as 5^n, so this pays for short chains
// or many rows: worthwhile() decides.
#include <Eigen/Dense>
#include <array>
#include <utility>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/kernels/lagrangian_kernel.hpp"

namespace gipdyn {

class LagrangianWeightSpaceMean {
 public:
  // Basis products per kinetic coefficient for these joints (a double: 5^n overflows int for long chains).
  static double kinetic_basis_size(const JointTypes& joints);
  // Whether a query in weight space costs less than one in kernel space over
  // `rows` training states with this kernel (measured costs; bench/RESULTS.md).
  static bool worthwhile(const LagrangianKernel& kernel, Eigen::Index rows);

  // alpha: the kernel-space weights (rows(X) n, sample-major), so that the mean
  // is sum_r K(x, x_r) alpha_r.
  LagrangianWeightSpaceMean(const LagrangianKernel& kernel, const Eigen::MatrixXd& X, const Eigen::VectorXd& alpha);

  // Buffers of one query; with them, mean() makes no heap allocation.
  class Workspace {
   public:
    explicit Workspace(const LagrangianWeightSpaceMean& mean);

   private:
    friend class LagrangianWeightSpaceMean;
    Eigen::MatrixXd coefficients;  // each h_ab (a row, pairs_'s order): value, then gradient in q
    Eigen::MatrixXd potential;     // V: value, then gradient in q
    std::array<Eigen::VectorXd, 2> contraction;  // the steps of contract(), in turn
    // The q whose coefficients and potential these are (cached_q false: none yet). The rigid-body
    // terms of a state are n + 2 queries at one q, and everything that costs is a function of q alone.
    Eigen::VectorXd q;
    bool cached_q = false;
  };

  int num_joints() const { return n_; }
  // sum_r K(x, x_r) alpha_r at the state x (3n entries) into tau (n entries). A query at the workspace's
  // previous q reuses its functions of q: O(n^3) instead of O(F n^2).
  void mean(const double* x, Workspace& workspace, double* tau) const;
  // The same for every row of X (rows x 3n), rows x n.
  Eigen::MatrixXd mean(const Eigen::Ref<const Eigen::MatrixXd>& X) const;

 private:
  // Value (column 0) and gradient in q (columns 1..n) of every product of one
  // basis function per joint, joint 0's index varying fastest.
  void features(const double* q, bool kinetic, Eigen::MatrixXd& out) const;
  // The weights' (rows indexed like the kinetic or potential basis products
  // of joints first_joint..n - 1, first_joint's fastest; a column each)
  // value and gradient in q at q: out, columns x (n + 1), zero in the columns
  // of the joints before first_joint.
  void contract(const double* q, bool kinetic, const Eigen::MatrixXd& weights, int first_joint, Workspace& w,
                Eigen::Ref<Eigen::MatrixXd> out) const;

  LagrangianKernel kernel_;
  int n_ = 0;
  std::vector<int> kinetic_size_, potential_size_;  // basis functions per joint
  Eigen::Index kinetic_count_ = 0, potential_count_ = 0;
  std::vector<std::pair<int, int>> pairs_;  // (a, b), a <= b, in the columns' order
  Eigen::MatrixXd kinetic_weights_;         // kinetic_count_ x pairs: posterior mean of each h_ab's weights
  // On a serial chain h_ab's weights vanish unless joints 0..a take their
  // constant basis function: the rows r * (the product of joints 0..a's basis
  // sizes). term_weights_[a] holds those rows of the columns (a, b >= a), so a
  // query contracts only them; empty off a serial chain.
  std::vector<Eigen::MatrixXd> term_weights_;
  Eigen::MatrixXd potential_weights_;       // potential_count_ x 1
  Eigen::MatrixXd friction_weights_;        // 4 x n, or empty without friction
};

}  // namespace gipdyn
