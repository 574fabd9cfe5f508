#pragma once
// The covariance-function interface. Every kernel keeps its value and its
// analytic gradient side by side, and stores its hyperparameters as logarithms
// (all of them are positive).
//
// Inputs are feature matrices Z with one sample per row (see features.hpp);
// a kernel reads the columns it was built with.
#include <Eigen/Dense>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"

namespace gipdyn {

class RegressorWorkspace;  // robot/dynamics.hpp

// The predictive mean of one query, k(z, Z) alpha, prepared once for a fixed
// (Z, alpha) by Kernel::plan_mean. A finite feature expansion folds alpha into
// its feature weights, so a query costs O(features) instead of N kernel values;
// a sum keeps one plan per child.
struct MeanPlan {
  Eigen::VectorXd weights;
  std::vector<MeanPlan> parts;
};

// Caller-owned buffers a kernel may use, so that repeated evaluations (one per
// optimiser step, one per control-loop query) reuse memory. One per thread.
// Kernel::contract_nll's default keeps W in `c`, so contract() implementations
// leave `c` alone.
struct KernelScratch {
  Eigen::MatrixXd a, b, c, d;
  // Low-rank kernels' (parametric, friction) N x F features and W times them,
  // apart from a and b: in a sum those hold another child's N x N matrices, and
  // sharing them would free and reallocate (and page in) 2 N^2 doubles at every
  // evaluation.
  Eigen::MatrixXd features, weighted_features;
  Eigen::VectorXd v, w;
  // Composite kernels' child rows in row(), one per nesting level (a product
  // inside a sum). A deque, so that a deeper level's first use does not move
  // the buffers of the levels above it.
  std::deque<Eigen::VectorXd> child_rows;
  size_t child_level = 0;
  // A sum's further children's Gram matrices in gram_lower, one per nesting
  // level likewise: an NLL evaluation then allocates no N x N matrix.
  std::deque<Eigen::MatrixXd> child_grams;
  size_t gram_level = 0;
  // Whose k(Z, Z) each slot of child_grams holds: a product's gram_lower
  // leaves its children's there, and its contraction in the same evaluation
  // reuses them instead of computing each again. A slot written for anything
  // else has an empty tag; a tag matches only the same kernel, hyperparameters
  // and rows (pointer, shape and contents).
  struct GramTag {
    std::uint64_t kernel = 0;  // Kernel::instance(); 0: none
    const double* z = nullptr;
    Eigen::Index rows = 0, cols = 0;
    std::uint64_t z_hash = 0;
    Eigen::VectorXd log_params;
  };
  std::deque<GramTag> child_gram_tags;
  // The parametric kernel's rigid-body regressor of one query (every joint's
  // row) and the buffers that compute it, made on first use for regressor_robot.
  // Every joint's model of a query asks for the same regressor in turn: the first
  // computes it for regressor_query, the others read it (its column count tells
  // friction columns apart).
  std::shared_ptr<RegressorWorkspace> regressor;
  const void* regressor_robot = nullptr;
  Eigen::MatrixXd regressor_rows;
  Eigen::VectorXd regressor_query;
  // The parametric kernel's row(): the stacked regressor (row r n + i: joint i of
  // training row r) of the rows in training_regressor_of, which row() compares
  // with the Z it is given, so that a query's k(z, Z) costs one regressor, not N.
  Eigen::MatrixXd training_regressor, training_regressor_of;
  Eigen::VectorXd regressor_weights;
};

class Kernel {
 public:
  virtual ~Kernel() = default;
  virtual std::unique_ptr<Kernel> clone() const = 0;
  // A number no other kernel object of the process has had, copies included:
  // what KernelScratch::GramTag names a Gram matrix's kernel by (an address can
  // be a freed kernel's).
  std::uint64_t instance() const { return instance_; }

  virtual int num_params() const = 0;
  // Dotted names, one per parameter, e.g. "joint2.cs.factor1.l_sin".
  virtual std::vector<std::string> param_names() const = 0;
  virtual Eigen::VectorXd log_params() const = 0;
  virtual void set_log_params(const Eigen::Ref<const Eigen::VectorXd>& log_params) = 0;

  // K(i, j) = k(Z1.row(i), Z2.row(j)).
  virtual void cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const = 0;
  // d(i) = k(Z.row(i), Z.row(i)).
  virtual void diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const = 0;
  // dK = dk(Z1, Z2) / d log(theta_p).
  virtual void gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p,
                               Eigen::MatrixXd& dK) const = 0;
  // grad(p) += sum_ij W(i,j) dk(z_i, z_j)/d log(theta_p) for K = k(Z, Z) and a full,
  // symmetric W. This is the only gradient the marginal likelihood needs, and it
  // never forms one N x N matrix per parameter.
  virtual void contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                        KernelScratch& scratch) const = 0;
  // contract() given K = k(Z, Z) already computed (a product's gram_lower
  // left it): kernels whose contraction needs K override it to skip
  // computing K again (RbfKernel). The default ignores K.
  virtual void contract_with_gram(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, const Eigen::MatrixXd& K,
                                  Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
    (void)K;
    contract(Z, W, grad, scratch);
  }
  // grad(p) += sum_ij W(i,j) dk(Z1.row(i), Z2.row(j))/d log(theta_p) for a W of
  // k(Z1, Z2)'s shape, and grad(p) += sum_i w(i) dk(z_i, z_i)/d log(theta_p):
  // the sparse GP's gradients (gp/sparse_gp.hpp). The defaults reduce both to
  // contract(): the first on [Z1; Z2] with the symmetric [[0, W/2], [W^T/2, 0]],
  // the second on diagonal blocks of a few rows. They use scratch.c.
  virtual void contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                              Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const;
  virtual void contract_diagonal(const Eigen::MatrixXd& Z, const Eigen::VectorXd& w, Eigen::Ref<Eigen::VectorXd> grad,
                                 KernelScratch& scratch) const;

  // Data-driven starting values for the optimiser: k(z, z) of about target_variance
  // on the training features Z. The default leaves the parameters as they are.
  virtual void initialize(const Eigen::MatrixXd& /*Z*/, double /*target_variance*/) {}

  // Narrows the box [lower, upper] the optimiser keeps the log-parameters in,
  // given the rows Z the model will be conditioned on, where a parameter's
  // extreme would let the model explain single rows and predict nonsense next to
  // them (FrictionKernel's Stribeck velocity). The default leaves the box.
  virtual void restrict_log_params(const Eigen::MatrixXd& /*Z*/, Eigen::Ref<Eigen::VectorXd> /*lower*/,
                                   Eigen::Ref<Eigen::VectorXd> /*upper*/) const {}

  // Fast paths. The defaults are correct for every kernel; kernels override
  // them when a fused implementation is faster.

  // Lower triangle of k(Z, Z) into K (N x N); the strict upper triangle is unspecified.
  virtual void gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& scratch) const;
  // grad(p) += sum_ij W_ij dK_ij/dlog(theta_p) with W = alpha alpha^T - Kinv, where
  // only the lower triangle of Kinv is read.
  virtual void contract_nll(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower,
                            Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const;
  // True where contract_nll does better than the default's W plus contract():
  // it reads alpha and Kinv_lower directly (GIP), or builds W only for the
  // children that need it (a sum). A sum builds one W for its other children.
  virtual bool fuses_nll_contraction() const { return false; }
  // W = alpha alpha^T - Kinv (both triangles) from the lower triangle of Kinv.
  static void nll_weights(const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower, Eigen::MatrixXd& W);
  // out(j) = k(z, Z.row(j)) for one query z (feature_dim entries). Kernels that
  // override it do not allocate once the scratch has its size.
  virtual void row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                   KernelScratch& scratch) const;
  // k(z, z). Kernels that override it do not allocate once the scratch has its size.
  virtual double self(const double* z, int feature_dim, KernelScratch& scratch) const;
  // k(z, Z) alpha for one query, through a plan that plan_mean made for the same
  // Z, alpha and hyperparameters (the model's, fixed once trained). krow (size
  // N) is a buffer. The defaults: no plan, and row() dotted with alpha; they do
  // not allocate where row() does not.
  virtual void plan_mean(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, MeanPlan& plan) const;
  virtual double mean_one(const double* z, const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha,
                          const MeanPlan& plan, Eigen::Ref<Eigen::VectorXd> krow, KernelScratch& scratch) const;
  // Kernels that are exactly k(z, z') = phi(z) diag(exp(log_params())) phi(z')^T, one
  // log-variance per feature in parameter order, put the features of every row of Z
  // into Phi and return true; training then evaluates the NLL in weight space
  // (gp/weight_space_nll.hpp). The default: false, Phi untouched.
  virtual bool weight_space_features(const Eigen::MatrixXd& /*Z*/, Eigen::MatrixXd& /*Phi*/) const { return false; }

 protected:
  Kernel() : instance_(next_instance()) {}
  Kernel(const Kernel&) : instance_(next_instance()) {}
  Kernel& operator=(const Kernel&) { return *this; }  // keeps its own instance

 private:
  static std::uint64_t next_instance();
  std::uint64_t instance_;
};

}  // namespace gipdyn
