#include "gipdyn/estimators/neural_network_estimator.hpp"

#include <cmath>
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {
namespace {

class NetworkQueryWorkspace final : public QueryWorkspace {
 public:
  NetworkQueryWorkspace(const NeuralNetwork& net, int num_joints)
      : QueryWorkspace(num_joints), net_(net), a_(net.widest_layer()), b_(net.widest_layer()) {}
  void predict(const double* x, double* tau) override { net_.predict_one(x, tau, a_, b_); }
  bool allocation_free() const override { return true; }

 private:
  const NeuralNetwork& net_;
  Eigen::VectorXd a_, b_;
};

}  // namespace

std::unique_ptr<QueryWorkspace> NeuralNetworkEstimator::make_query_workspace() const {
  return std::make_unique<NetworkQueryWorkspace>(net_, joints().size());
}

ModelContainer NeuralNetworkEstimator::to_container() const {
  ModelContainer c;
  c.header["estimator"] = name();
  net_.to_container(c);
  return c;
}

nlohmann::json NeuralNetworkEstimator::summary() const {
  nlohmann::json s = {{"estimator", name()},
                      {"weights", net_.num_weights()},
                      {"final_training_loss", net_.final_loss()},
                      {"epochs_run", net_.epochs_run()},
                      {"kept_epoch", net_.kept_epoch()}};
  if (std::isfinite(net_.validation_loss())) s["validation_loss"] = net_.validation_loss();
  if (net_.held_out_row_count() > 0) s["held_out_rows"] = net_.held_out_row_count();
  return s;
}

}  // namespace gipdyn
