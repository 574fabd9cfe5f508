#include "gipdyn/estimators/estimator_file.hpp"

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/fisherian.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/estimators/neural_network_estimator.hpp"
#include "gipdyn/model/model_file.hpp"

namespace gipdyn {

std::unique_ptr<Estimator> estimator_from_container(const ModelContainer& c, const std::string& what) {
  std::string kind;
  try {
    kind = c.header.value("estimator", "gp");  // format 1 files hold GP models only
    if (kind == "gp") return std::make_unique<GpEstimator>(model_from_container(c, what));
    if (kind == "lip" || kind == "lip+friction") return std::make_unique<LagrangianEstimator>(LagrangianEstimator::from_container(c, what));
    if (kind == "fe" || kind == "chain") return std::make_unique<FisherianEstimator>(FisherianEstimator::from_container(c, what));
    if (kind == "nn") return std::make_unique<NeuralNetworkEstimator>(NeuralNetwork::from_container(c, what));
  } catch (const nlohmann::json::exception& e) {
    throw Error(what + " is corrupted (" + std::string(e.what()) + "); re-save the model");
  }
  throw Error(what + " holds an unknown estimator '" + kind + "'; upgrade gipdyn");
}

void save_estimator(const Estimator& estimator, const std::string& path) {
  write_container(estimator.to_container(), path);
}

std::unique_ptr<Estimator> load_estimator(const std::string& path) {
  const std::string what = "model file '" + path + "'";
  return estimator_from_container(unpack_container(read_model_bytes(path), what), what);
}

}  // namespace gipdyn
