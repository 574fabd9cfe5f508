#pragma once
// FE, the Fisherian estimator of docs/method.md section 6: ordinary least squares of the
// stacked torques on the rigid-body regressor of the nominal robot, restricted
// to the base parameters (robot/dynamics.hpp: a column-pivoted QR picks a
// maximal set of independent regressor columns; the others are fixed at zero,
// which leaves the predicted torques unchanged).
#include "gipdyn/estimators/estimator.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/robot/robot_model.hpp"

namespace gipdyn {

class FisherianEstimator final : public Estimator {
 public:
  // weights: one per regressor column (10n, or 12n with friction).
  FisherianEstimator(RobotPrior prior, Eigen::VectorXd weights);

  // Throws gipdyn::Error if the prior has no robot or the shapes disagree.
  static FisherianEstimator fit(const RobotPrior& prior, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y);

  // The same model named "chain": its robot is a chain identified from the log
  // (robot/chain_identification.hpp), described by `report`.
  FisherianEstimator identified_by(std::string report) &&;

  std::string name() const override;
  const JointTypes& joints() const override { return joints_; }
  Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const override;
  // Single queries make no heap allocation: the regressor is built in the workspace.
  std::unique_ptr<QueryWorkspace> make_query_workspace() const override;
  ModelContainer to_container() const override;
  nlohmann::json summary() const override;
  static FisherianEstimator from_container(const ModelContainer& c, const std::string& what);

  const Eigen::VectorXd& weights() const { return weights_; }
  int num_base_parameters() const { return base_rank_; }

 private:
  RobotPrior prior_;
  JointTypes joints_;
  Eigen::VectorXd weights_;
  int base_rank_ = 0;
  std::string identification_;  // the chain identification's brief report; empty for fe
};

}  // namespace gipdyn
