#include "gipdyn/estimators/gp_estimator.hpp"

#include "gipdyn/model/model_file.hpp"
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {
namespace {

class GpQueryWorkspace final : public QueryWorkspace {
 public:
  explicit GpQueryWorkspace(const InverseDynamicsModel& model) : QueryWorkspace(model.num_joints()), prediction_(model) {}
  void predict(const double* x, double* tau) override { prediction_.predict(x, tau); }
  void rigid_body_terms(const double* q, const double* qd, double* gravity, double* M, double* bias) override {
    prediction_.rigid_body_terms(q, qd, gravity, M, bias);
  }
  bool allocation_free() const override { return true; }

 private:
  PredictionWorkspace prediction_;
};

}  // namespace

std::unique_ptr<QueryWorkspace> GpEstimator::make_query_workspace() const {
  return std::make_unique<GpQueryWorkspace>(model_);
}

ModelContainer GpEstimator::to_container() const { return model_to_container(model_); }

nlohmann::json GpEstimator::summary() const {
  nlohmann::json joints = nlohmann::json::array();
  for (int j = 0; j < model_.num_joints(); ++j) {
    nlohmann::json hp = nlohmann::json::object();
    for (const auto& [name, value] : model_.hyperparameters(j)) hp[name] = value;
    joints.push_back({{"joint", j + 1}, {"nll", model_.joint_gp(j).nll()}, {"hyperparameters", hp}});
  }
  return {{"estimator", "gp"}, {"kernel", model_.kernel_name()}, {"joints", joints}};
}

}  // namespace gipdyn
