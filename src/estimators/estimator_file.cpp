#include "gipdyn/estimators/estimator_file.hpp"

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/estimators/fisherian.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/estimators/neural_network_estimator.hpp"
#include "gipdyn/estimators/per_joint_estimator.hpp"
#include "gipdyn/model/model_file.hpp"
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {

namespace {

std::unique_ptr<Estimator> read_estimator(const ModelContainer& c, const std::string& what) {
  std::string kind;
  try {
    kind = c.header.value("estimator", "gp");  // format 1 files hold GP models only
    if (kind == "gp") return std::make_unique<GpEstimator>(model_from_container(c, what));
    if (kind == PerJointEstimator::kName) return PerJointEstimator::from_container(c, what);
    if (const EstimatorSpec* spec = find_estimator_spec(kind)) {
      switch (spec->family) {
        case EstimatorFamily::Lagrangian:
          return std::make_unique<LagrangianEstimator>(LagrangianEstimator::from_container(c, what));
        case EstimatorFamily::Fisherian:
          return std::make_unique<FisherianEstimator>(FisherianEstimator::from_container(c, what));
        case EstimatorFamily::NeuralNetwork:
          return std::make_unique<NeuralNetworkEstimator>(NeuralNetwork::from_container(c, what));
        case EstimatorFamily::Gp: break;  // stored as "gp", the kernel beside it
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw Error(what + " is corrupted (" + std::string(e.what()) + "); re-save the model");
  }
  throw Error(what + " holds an unknown estimator '" + kind + "'; upgrade gipdyn");
}

}  // namespace

std::unique_ptr<Estimator> estimator_from_container(const ModelContainer& c, const std::string& what) {
  std::unique_ptr<Estimator> e = read_estimator(c, what);
  if (c.header.contains("teacher")) e->set_teaching_record(c.header.at("teacher"));
  if (c.header.contains("selection")) e->set_selection_record(c.header.at("selection"));
  if (c.header.contains("options")) e->set_options_record(c.header.at("options"));
  return e;
}

ModelContainer estimator_container(const Estimator& estimator) {
  ModelContainer c = estimator.to_container();
  if (const nlohmann::json* record = estimator.teaching_record()) c.header["teacher"] = *record;
  if (const nlohmann::json* record = estimator.selection_record()) c.header["selection"] = *record;
  if (const nlohmann::json* record = estimator.options_record()) c.header["options"] = *record;
  return c;
}

void save_estimator(const Estimator& estimator, const std::string& path) {
  write_container(estimator_container(estimator), path);
}

std::unique_ptr<Estimator> load_estimator(const std::string& path) {
  const std::string what = "model file '" + path + "'";
  return estimator_from_container(unpack_container(read_model_bytes(path), what), what);
}

}  // namespace gipdyn
