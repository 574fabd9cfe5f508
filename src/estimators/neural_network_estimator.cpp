#include "gipdyn/estimators/neural_network_estimator.hpp"

namespace gipdyn {

ModelContainer NeuralNetworkEstimator::to_container() const {
  ModelContainer c;
  c.header["estimator"] = "nn";
  net_.to_container(c);
  return c;
}

nlohmann::json NeuralNetworkEstimator::summary() const {
  return {{"estimator", "nn"}, {"weights", net_.num_weights()}, {"final_training_loss", net_.final_loss()}};
}

}  // namespace gipdyn
