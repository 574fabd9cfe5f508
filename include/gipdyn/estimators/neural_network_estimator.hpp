#pragma once
// A trained NeuralNetwork as an Estimator.
#include "gipdyn/estimators/estimator.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/estimators/neural_network.hpp"

namespace gipdyn {

class NeuralNetworkEstimator final : public Estimator {
 public:
  explicit NeuralNetworkEstimator(NeuralNetwork net) : net_(std::move(net)) {}
  std::string name() const override { return estimator_name(EstimatorFamily::NeuralNetwork); }
  const JointTypes& joints() const override { return net_.joints(); }
  Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const override { return net_.predict(X); }
  ModelContainer to_container() const override;
  nlohmann::json summary() const override;
  std::unique_ptr<QueryWorkspace> make_query_workspace() const override;  // allocation-free

  const NeuralNetwork& network() const { return net_; }

 private:
  NeuralNetwork net_;
};

}  // namespace gipdyn
