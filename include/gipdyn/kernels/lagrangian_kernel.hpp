#pragma once
// The Lagrangian-inspired polynomial (LIP) kernel (docs/method.md section 11).
//
// GP priors go on the energies, not on the torques:
//
//   kinetic   T(q, qd) = sum_{a<=b} qd_a qd_b h_ab(q),  h_ab ~ GP(0, lambda_ab p_T(q, q'))
//   potential V(q)     ~ GP(0, p_V(q, q'))
//
// p_T is a product over joints of MPK_2 factors, p_V one of MPK_1 factors, on
// z = (cos q, sin q) for a revolute joint and z = (q) for a prismatic one:
// the inertia matrix of a rigid arm has degree 2, its potential energy degree 1,
// in every joint's z. The torques follow from the Lagrange equations,
//
//   tau_i = d/dt dL/dqd_i - dL/dq_i,  L = T - V,
//
// a linear operator, so the torques of all joints are one GP whose covariance
// is that operator applied to both arguments of the energy kernels. This class
// evaluates that (n x n per pair of states) covariance in closed form, its
// gradient with respect to the log-hyperparameters, and the covariance of
// each energy with the torques (to estimate T and V from torque data alone).
//
// On a serial chain whose joints are ordered from the base to the tip
// (serial_chain, the default of the estimators), h_ab depends only on the
// joints after min(a, b): the inertia matrix's entry ab, written in the frame
// of link min(a, b), involves only the links and joints beyond it. Its
// position kernel is then the product of p_T's factors over those joints
// alone (h_nn is a constant), which removes most of the coefficients' freedom
// that no serial arm uses (docs/method.md section 11).
//
// With friction, each joint's torque gets an independent dissipative term
// beside the Lagrangian ones, the smooth Stribeck friction and offset of
// kernels/friction_kernel.hpp on its own velocity: it adds
// k_f,i(qd1_i, qd2_i) to cov(tau_i(x1), tau_i(x2)) and nothing to the energies.
//
// States are rows x = (q, qd, qdd) of length 3n; covariance matrices of many
// states are sample-major: entry (r n + i, s n + j) is cov(tau_i(x_r), tau_j(x_s)).
#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn {

class LagrangianKernel {
  struct PairTerms;

 public:
  explicit LagrangianKernel(JointTypes joints, bool friction = false, bool serial_chain = false);

  const JointTypes& joints() const { return joints_; }
  bool serial_chain() const { return serial_chain_; }
  bool has_friction() const { return friction_offset_ >= 0; }
  int num_params() const { return static_cast<int>(log_params_.size()); }
  // "kinetic.velocity.w1_2", "kinetic.joint2.factor1.l_cos", "potential.joint1.bias", ...,
  // and with friction "friction.joint1.s_offset", ... (FrictionKernel's six per joint).
  std::vector<std::string> param_names() const;
  const Eigen::VectorXd& log_params() const { return log_params_; }
  // Throws gipdyn::Error unless the length is num_params() and every entry is finite.
  void set_log_params(const Eigen::Ref<const Eigen::VectorXd>& log_params);

  // Scratch for one pair of states, reused across calls (one per thread):
  // with it, torque_block makes no heap allocation.
  class PairScratch {
   public:
    explicit PairScratch(const LagrangianKernel& kernel);
    ~PairScratch();
    PairScratch(PairScratch&&) noexcept;
    PairScratch& operator=(PairScratch&&) noexcept;

   private:
    friend class LagrangianKernel;
    std::unique_ptr<PairTerms> terms_;
  };

  // cov(tau(x1), tau(x2)), n x n.
  void torque_block(const double* x1, const double* x2, Eigen::Ref<Eigen::MatrixXd> block) const;
  void torque_block(const double* x1, const double* x2, PairScratch& scratch, Eigen::Ref<Eigen::MatrixXd> block) const;
  // (rows(X1) n) x (rows(X2) n).
  Eigen::MatrixXd torque_covariance(const Eigen::MatrixXd& X1, const Eigen::MatrixXd& X2) const;
  // Lower triangle of torque_covariance(X, X) (the strict upper one is unspecified).
  void torque_gram_lower(const Eigen::MatrixXd& X, Eigen::MatrixXd& K) const;
  // grad(p) += sum_ab W_ab dK_ab / dlog(theta_p), K = torque_covariance(X, X),
  // for a symmetric W of which only the lower triangle is read.
  void add_gradient(const Eigen::MatrixXd& X, const Eigen::MatrixXd& W_lower, Eigen::Ref<Eigen::VectorXd> grad) const;

  // cov(T(x), tau(X)) and cov(V(q), tau(X)), rows(X) n each; x is a full state
  // (only q and qd are read).
  Eigen::RowVectorXd kinetic_torque_covariance(const double* x, const Eigen::MatrixXd& X) const;
  Eigen::RowVectorXd potential_torque_covariance(const double* x, const Eigen::MatrixXd& X) const;

  // Data-driven start: every position factor is 1 on the diagonal (weights
  // share it with the bias), then the velocity weights and the potential's
  // factors are scaled so that each energy's torques have a prior variance of
  // about target_variance / 2 on the states X; friction starts as
  // FrictionKernel::initialize with target_variance / 4 on each joint.
  void initialize(const Eigen::MatrixXd& X, double target_variance);
  // Each joint's FrictionKernel::restrict_log_params on the states X.
  void restrict_log_params(const Eigen::MatrixXd& X, Eigen::Ref<Eigen::VectorXd> lower,
                           Eigen::Ref<Eigen::VectorXd> upper) const;

  // The kernel as sums of monomials (kernels/lagrangian_weight_space.hpp). Joint
  // m's pair of kinetic factors is sum_k w_k u_k(q) u_k(q') over the monomials
  // u = (1, cos, sin, cos^2, sin^2, cos sin) of a revolute joint, (1, q, q^2) of
  // a prismatic one; its potential factor over (1, cos, sin) or (1, q). These
  // write the weights w (6 or 3, 3 or 2 entries).
  void kinetic_monomial_weights(int joint, double* weights) const;
  void potential_monomial_weights(int joint, double* weights) const;
  // The prior variance of h_ab: lambda_ab (a <= b).
  double velocity_weight(int a, int b) const { return a == b ? nu_(a, a) : 2.0 * nu_(a, b); }
  // h_ab's position kernel (a <= b) is the product of p_T's factors over the
  // joints from first_kinetic_joint(a) on: a + 1 on a serial chain, 0 otherwise.
  int first_kinetic_joint(int a) const;
  // Joint m's friction term as FrictionKernel's four features at velocity v and
  // their prior variances (s_offset, s_viscous, s_coulomb, s_stribeck); only
  // with friction.
  Eigen::Vector4d friction_features_at(int joint, double v) const;
  Eigen::Vector4d friction_variances(int joint) const;

  // Indices into log_params().
  int num_velocity_weights() const { return n_ * (n_ + 1) / 2; }
  int kinetic_position_offset() const { return num_velocity_weights(); }
  int potential_offset() const { return potential_offset_; }
  // First friction parameter (joint m's start at friction_offset() + 6 m), or -1.
  int friction_offset() const { return friction_offset_; }

 private:
  // Per-joint jets of the position kernels for one pair of states.
  void position_jets(const double* x1, const double* x2, PairTerms& t) const;
  // The states of X as columns (q, qd, qdd), each followed by its joints'
  // cosines and then sines: an O(N^2) loop over pairs computes them once per state.
  Eigen::MatrixXd with_trigonometry(const Eigen::MatrixXd& X) const;
  // The kinetic energy is a sum of terms, each with one position kernel: on a
  // serial chain term c holds the coefficients h_cb (b >= c), otherwise one
  // term holds them all. This sets a term's position quantities and velocity
  // products for a pair whose jets position_jets has set. On a chain each
  // term's position kernel is the next one's times one factor, so the terms
  // are visited from the last to the first, each right after the one above it.
  int num_kinetic_terms() const { return serial_chain_ ? n_ : 1; }
  void kinetic_term_quantities(const double* x1, const double* x2, int term, PairTerms& t) const;
  // The pair's velocity products that every term reads (e, v5, v7).
  void velocity_products(const double* x1, const double* x2, PairTerms& t) const;
  // A term's vectors and blocks are zero before joint term_support(term).
  int term_support(int term) const;
  // out = (the term's entries of nu) v, in O(n) on a chain.
  void term_product(int term, const Eigen::VectorXd& v, Eigen::VectorXd& out) const;
  // The term's entries of nu, times scale, written into out (each entry belongs to one term).
  void write_term_weights(int term, double scale, Eigen::MatrixXd& out) const;
  // sum over the term's entries (a, b) of nu_ab M_ab.
  double term_contraction(int term, const Eigen::MatrixXd& M) const;
  // The blocks of cov(tau(X1), tau(X2)), or only those on and below the diagonal.
  void fill_blocks(const Eigen::MatrixXd& X1, const Eigen::MatrixXd& X2, bool lower_only, Eigen::MatrixXd& K) const;
  void assemble_block(const double* x1, const double* x2, PairTerms& t, Eigen::Ref<Eigen::MatrixXd> block) const;
  void add_pair_gradient(const double* x1, const double* x2, const Eigen::Ref<const Eigen::MatrixXd>& W, PairTerms& t,
                         Eigen::Ref<Eigen::VectorXd> grad) const;
  int factor_size(int joint) const { return joints_.is_revolute(joint) ? 3 : 2; }
  // Joint m's friction covariance k_f,m(v1, v2), and its gradient (times w) into grad.
  double friction_covariance(int m, double v1, double v2) const;
  void add_friction_gradient(int m, double v1, double v2, double w, Eigen::Ref<Eigen::VectorXd> grad) const;

  JointTypes joints_;
  int n_ = 0;
  bool serial_chain_ = false;
  int potential_offset_ = 0;
  int friction_offset_ = -1;
  std::vector<int> kinetic_offset_;    // per joint: its first factor's bias; the second factor follows
  std::vector<int> potential_joint_;   // per joint: its factor's bias
  Eigen::VectorXd log_params_;
  Eigen::VectorXd params_;    // exp(log_params_)
  Eigen::MatrixXd nu_;        // symmetric velocity weights: lambda_aa on the diagonal, lambda_ab / 2 off it
};

}  // namespace gipdyn
