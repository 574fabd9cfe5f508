#pragma once
// LIP: one GP over the torques of all joints with the Lagrangian kernel
// (kernels/lagrangian_kernel.hpp, docs/method.md section 11). The joints are
// coupled through the energies, so the system is (N n) x (N n): memory and
// time grow with n^2 and n^3 over a per-joint GP's (measured in
// bench/RESULTS.md); train it on fewer rows. On short chains (a SCARA: fewer
// features than torques) the likelihood is evaluated and the model
// conditioned in weight space instead (gp/lagrangian_weight_space_nll.hpp),
// at a cost that grows only linearly with the rows.
//
// Besides torques it estimates the kinetic energy and the potential energy
// (the latter up to a constant, which torques cannot identify).
#include <Eigen/Dense>
#include <memory>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/estimator.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/kernels/lagrangian_kernel.hpp"
#include "gipdyn/kernels/lagrangian_weight_space.hpp"
#include "gipdyn/model/fit_report.hpp"
#include "gipdyn/model/hyperparameter_search.hpp"
#include "gipdyn/progress.hpp"

namespace gipdyn {

struct LagrangianOptions {
  SearchSettings search;
  // The joints are ordered from the base to the tip of a serial chain, as in
  // every URDF chain, DH table and robot log, so the inertia matrix's entry ab
  // depends only on the joints after min(a, b), and the kernel says so
  // (LagrangianKernel's serial_chain, docs/method.md section 11). Off: every
  // entry may depend on every joint (the LIP paper's kernel), for joints in
  // another order.
  bool serial_chain = true;
  // Each joint's smooth friction and offset beside the energies
  // (LagrangianKernel): the estimator "lip+friction".
  bool friction = false;
  // Warm start: with at least twice this many hyperparameter rows, every
  // start first searches on a constant-step subsample of this many of them
  // (each evaluation about (rows/N)^2 of the cost), and the best subsample
  // optimum then continues on all of them. Only where the subsample holds at
  // least 10 torque values (rows x joints) per hyperparameter: fewer leave
  // its optimum in another basin of the NLL than the one the search on all
  // rows finds, and the search then runs on all rows from the start. 0:
  // search on all of them from the start.
  int warm_start_rows = 0;

  // Throws gipdyn::Error naming the bad field.
  void validate() const;
};

class LagrangianEstimator final : public Estimator {
 public:
  // A fitted model: the kernel, the training states X (N x 3n), the weights
  // alpha = K^-1 y (N n, sample-major) of the scaled torques, the torques' scale.
  LagrangianEstimator(LagrangianKernel kernel, Eigen::VectorXd noise_variances, double torque_scale,
                      Eigen::MatrixXd X, Eigen::VectorXd alpha);

  struct FitOutcome {
    FitReport report;  // one entry per joint, all from the one coupled optimisation
    std::unique_ptr<LagrangianEstimator> estimator;  // null unless report.ok()
  };
  // Maximum marginal likelihood, searched as options.search says (its
  // hyperparameter_rows: optimise on that constant-step subsample, then
  // condition on every row once, the way to a few thousand rows; its threads:
  // how many starts run side by side, 0: all, sharing the cores; the result
  // does not depend on it). Throws gipdyn::Error for bad options or data, or a
  // system too large for the memory available.
  static FitOutcome fit(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints,
                        const LagrangianOptions& options, const ProgressCallback& progress = {});

  std::string name() const override { return estimator_name(EstimatorFamily::Lagrangian, &EstimatorSpec::friction, kernel_.has_friction()); }
  const JointTypes& joints() const override { return kernel_.joints(); }
  // In weight space where that is cheaper (LagrangianWeightSpaceMean::worthwhile:
  // a SCARA past about 10 rows, a 6R arm past about 35 on the serial chain and
  // 350 with the full kernel), else one n x n block per training row.
  Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const override;
  // Single queries make no heap allocation, in either space.
  bool queries_in_weight_space() const { return weight_space_ != nullptr; }
  std::unique_ptr<QueryWorkspace> make_query_workspace() const override;
  ModelContainer to_container() const override;
  nlohmann::json summary() const override;
  static LagrangianEstimator from_container(const ModelContainer& c, const std::string& what);

  // The same model able to give predictive variances: it holds the factor of
  // the (N n)^2 training covariance (built here once, O((N n)^3), not saved in
  // model files). Throws gipdyn::Error when it cannot be factorised or would
  // not fit in memory.
  LagrangianEstimator with_variance() const;
  bool has_variance() const { return factor_.size() > 0; }
  // Posterior standard deviation of each joint's noise-free torque at every
  // row of X (M x n, the torques' units). Throws gipdyn::Error unless
  // has_variance().
  Eigen::MatrixXd predict_std(const Eigen::Ref<const Eigen::MatrixXd>& X) const;

  // Kinetic energy at every row of X (rows x 3n or rows x 2n: q, qd), J.
  Eigen::VectorXd kinetic_energy(const Eigen::Ref<const Eigen::MatrixXd>& X) const;
  // Potential energy at every row of Q (rows x n or more: q first), J, up to an
  // additive constant; the GP's estimate of it is the prior's, near zero.
  Eigen::VectorXd potential_energy(const Eigen::Ref<const Eigen::MatrixXd>& Q) const;

  const LagrangianKernel& kernel() const { return kernel_; }
  const Eigen::VectorXd& noise_variances() const { return noise_; }  // per joint, N m^2 (or N^2)
  const Eigen::MatrixXd& training_inputs() const { return X_; }
  // alpha and the torques' scale: the mean is torque_scale() sum_r K(x, x_r) alpha_r.
  const Eigen::VectorXd& weights() const { return alpha_; }
  double torque_scale() const { return scale_; }

 private:
  Eigen::MatrixXd state_rows(const Eigen::Ref<const Eigen::MatrixXd>& X, int min_cols, const char* what) const;
  template <class Covariance>
  Eigen::VectorXd energy(const Eigen::MatrixXd& states, Covariance&& covariance) const;

  LagrangianKernel kernel_;
  Eigen::VectorXd noise_;  // in the torques' units squared
  double scale_ = 1.0;
  Eigen::MatrixXd X_;
  Eigen::VectorXd alpha_;
  std::shared_ptr<const LagrangianWeightSpaceMean> weight_space_;  // null where kernel space is cheaper
  Eigen::MatrixXd factor_;  // lower Cholesky factor of the scaled training covariance plus noise, or empty
};

}  // namespace gipdyn
