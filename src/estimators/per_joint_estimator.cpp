#include "gipdyn/estimators/per_joint_estimator.hpp"

#include <nlohmann/json.hpp>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {
namespace {

std::string array_prefix(size_t model) { return "model" + std::to_string(model) + "/"; }

// Every model's workspace, and each joint's answer copied from its model's.
class PerJointWorkspace final : public QueryWorkspace {
 public:
  explicit PerJointWorkspace(const PerJointEstimator& estimator)
      : QueryWorkspace(estimator.joints().size()), joint_model_(estimator.joint_model()) {
    const size_t n = joint_model_.size();
    for (const auto& model : estimator.models()) workspaces_.push_back(model->make_query_workspace());
    tau_.resize(workspaces_.size() * n);
    gravity_.resize(workspaces_.size() * n);
    bias_.resize(workspaces_.size() * n);
    M_.resize(workspaces_.size() * n * n);
  }

  void predict(const double* x, double* tau) override {
    const size_t n = joint_model_.size();
    for (size_t m = 0; m < workspaces_.size(); ++m) workspaces_[m]->predict(x, tau_.data() + m * n);
    for (size_t i = 0; i < n; ++i) tau[i] = tau_[static_cast<size_t>(joint_model_[i]) * n + i];
  }

  bool allocation_free() const override {
    for (const auto& w : workspaces_)
      if (!w->allocation_free()) return false;
    return true;
  }

  void rigid_body_terms(const double* q, const double* qd, double* gravity, double* M, double* bias) override {
    const size_t n = joint_model_.size();
    for (size_t m = 0; m < workspaces_.size(); ++m)
      workspaces_[m]->rigid_body_terms(q, qd, gravity_.data() + m * n, M_.data() + m * n * n,
                                       bias ? bias_.data() + m * n : nullptr);
    for (size_t i = 0; i < n; ++i) {  // joint i's row of every term, from its model
      const size_t m = static_cast<size_t>(joint_model_[i]);
      gravity[i] = gravity_[m * n + i];
      if (bias) bias[i] = bias_[m * n + i];
      for (size_t j = 0; j < n; ++j) M[i * n + j] = M_[m * n * n + i * n + j];  // row-major
    }
  }

 private:
  std::vector<int> joint_model_;
  std::vector<std::unique_ptr<QueryWorkspace>> workspaces_;
  std::vector<double> tau_, gravity_, bias_, M_;  // every model's answer, model after model
};

}  // namespace

PerJointEstimator::PerJointEstimator(std::vector<std::shared_ptr<const Estimator>> models,
                                     std::vector<int> joint_model)
    : models_(std::move(models)), joint_model_(std::move(joint_model)) {
  if (models_.empty()) throw Error("PerJointEstimator: no models");
  for (const auto& model : models_) {
    if (!model) throw Error("PerJointEstimator: a model is null");
    if (dynamic_cast<const PerJointEstimator*>(model.get()))
      throw Error("PerJointEstimator: a model is itself per joint; give its models instead");
    if (model->joints().str() != models_.front()->joints().str())
      throw Error("PerJointEstimator: the models are of different joints (" + models_.front()->joints().str() +
                  " and " + model->joints().str() + ")");
  }
  if (static_cast<int>(joint_model_.size()) != models_.front()->joints().size())
    throw Error("PerJointEstimator: " + std::to_string(joint_model_.size()) + " joint models for " +
                std::to_string(models_.front()->joints().size()) + " joints");
  std::vector<bool> answers(models_.size(), false);
  for (int m : joint_model_) {
    if (m < 0 || m >= static_cast<int>(models_.size()))
      throw Error("PerJointEstimator: joint model index " + std::to_string(m) + " outside 0.." +
                  std::to_string(models_.size() - 1));
    answers[static_cast<size_t>(m)] = true;
  }
  for (size_t m = 0; m < models_.size(); ++m)
    if (!answers[m]) throw Error("PerJointEstimator: model " + std::to_string(m) + " answers no joint");
}

Eigen::MatrixXd PerJointEstimator::predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  Eigen::MatrixXd tau(X.rows(), static_cast<Eigen::Index>(joint_model_.size()));
  for (size_t m = 0; m < models_.size(); ++m) {
    const Eigen::MatrixXd answer = models_[m]->predict(X);
    for (size_t i = 0; i < joint_model_.size(); ++i)
      if (joint_model_[i] == static_cast<int>(m)) tau.col(static_cast<Eigen::Index>(i)) = answer.col(static_cast<Eigen::Index>(i));
  }
  return tau;
}

ModelContainer PerJointEstimator::to_container() const {
  ModelContainer c;
  c.header["estimator"] = kName;
  c.header["joints"] = joints().str();
  c.header["joint_models"] = joint_model_;
  c.header["models"] = nlohmann::json::array();
  for (size_t m = 0; m < models_.size(); ++m) {
    ModelContainer own = estimator_container(*models_[m]);
    c.header["models"].push_back(std::move(own.header));
    for (auto& [name, value] : own.arrays) c.add(array_prefix(m) + name, std::move(value));
  }
  return c;
}

std::unique_ptr<PerJointEstimator> PerJointEstimator::from_container(const ModelContainer& c, const std::string& what) {
  const nlohmann::json& headers = c.header.at("models");
  std::vector<std::shared_ptr<const Estimator>> models;
  for (size_t m = 0; m < headers.size(); ++m) {
    ModelContainer own;
    own.header = headers.at(m);
    const std::string prefix = array_prefix(m);
    for (const auto& [name, value] : c.arrays)
      if (name.rfind(prefix, 0) == 0) own.add(name.substr(prefix.size()), value);
    models.push_back(estimator_from_container(own, what + ", its model " + std::to_string(m)));
  }
  std::vector<int> joint_model = c.header.at("joint_models").get<std::vector<int>>();
  try {
    return std::make_unique<PerJointEstimator>(std::move(models), std::move(joint_model));
  } catch (const Error& e) {
    throw Error(what + " is corrupted (" + std::string(e.what()) + "); re-save the model");
  }
}

nlohmann::json PerJointEstimator::summary() const {
  nlohmann::json s;
  s["estimator"] = kName;
  s["joint_models"] = joint_model_names();
  s["models"] = nlohmann::json::array();
  for (const auto& model : models_) s["models"].push_back(model->summary());
  return s;
}

std::unique_ptr<QueryWorkspace> PerJointEstimator::make_query_workspace() const {
  return std::make_unique<PerJointWorkspace>(*this);
}

bool PerJointEstimator::gives_rigid_body_terms() const {
  for (const auto& model : models_)
    if (!model->gives_rigid_body_terms()) return false;
  return true;
}

std::string PerJointEstimator::why_no_rigid_body_terms() const {
  std::string without;
  int count = 0;
  for (size_t j = 0; j < joint_model_.size(); ++j) {
    const Estimator& model = *models_[static_cast<size_t>(joint_model_[j])];
    if (!model.gives_rigid_body_terms())
      without += (count++ == 0 ? "" : ", ") + std::to_string(j + 1) + " (" + model.name() + ")";
  }
  return "a model chosen per joint gives them only where every joint's model does, and that of joint" +
         std::string(count > 1 ? "s " : " ") + without + (count > 1 ? " do" : " does") + " not";
}

std::vector<std::string> PerJointEstimator::joint_model_names() const {
  std::vector<std::string> names;
  for (int m : joint_model_) names.push_back(models_[static_cast<size_t>(m)]->name());
  return names;
}

}  // namespace gipdyn
