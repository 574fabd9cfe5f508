#pragma once
// A GP model (InverseDynamicsModel) as an Estimator.
#include "gipdyn/estimators/estimator.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"

namespace gipdyn {

class GpEstimator final : public Estimator {
 public:
  explicit GpEstimator(InverseDynamicsModel model) : model_(std::move(model)) {}
  std::string name() const override { return model_.kernel_name(); }
  const JointTypes& joints() const override { return model_.joints(); }
  Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const override { return model_.predict(X); }
  ModelContainer to_container() const override;
  nlohmann::json summary() const override;
  const InverseDynamicsModel* gp_model() const override { return &model_; }
  std::unique_ptr<QueryWorkspace> make_query_workspace() const override;  // a PredictionWorkspace

  const InverseDynamicsModel& model() const { return model_; }

 private:
  InverseDynamicsModel model_;
};

}  // namespace gipdyn
