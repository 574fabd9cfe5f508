#pragma once
// Each joint's torque from its own model. Where candidates lead on different
// joints (model_selection.hpp: a real log whose wrist is best learned by a
// bounded model and whose other joints by GIP), the choice by evidence keeps,
// per joint, the model that predicted that joint best, and this estimator
// answers each joint from it. Its models are fitted on the same joints, each
// on the whole log as its own options say, and are read-only like any
// estimator's; several joints may share one model.
#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/estimator.hpp"

namespace gipdyn {

class PerJointEstimator final : public Estimator {
 public:
  // The name model files and reports give it ("estimator" in a model file's header).
  static constexpr const char* kName = "chosen-per-joint";

  // models: distinct fitted estimators of the same joints; joint_model[i]: the index in models of joint i's.
  // Throws gipdyn::Error where they differ in joints, an index is out of range, a model answers no joint,
  // or a model is itself a PerJointEstimator.
  PerJointEstimator(std::vector<std::shared_ptr<const Estimator>> models, std::vector<int> joint_model);

  std::string name() const override { return kName; }
  const JointTypes& joints() const override { return models_.front()->joints(); }
  Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const override;
  // Header {"estimator": "chosen-per-joint", "joint_models": [index per joint], "models": [each model's header]};
  // model k's arrays under "model<k>/" (docs/model-format.md).
  ModelContainer to_container() const override;
  nlohmann::json summary() const override;
  // One workspace per model; allocation-free where every model's is. Its
  // rigid_body_terms() takes each joint's row from its model's.
  std::unique_ptr<QueryWorkspace> make_query_workspace() const override;
  // Every model's; rows of M, gravity and the bias come from each joint's model.
  bool gives_rigid_body_terms() const override;
  // Names the joints whose models give none.
  std::string why_no_rigid_body_terms() const override;
  // None: a joint's predictive variance and the learned noise of several
  // models do not make one calibrated model (predict gives means only).
  bool gives_uncertainty() const override { return false; }

  const std::vector<std::shared_ptr<const Estimator>>& models() const { return models_; }
  const std::vector<int>& joint_model() const { return joint_model_; }
  // Per joint, its model's name.
  std::vector<std::string> joint_model_names() const;

  // The models of a container that to_container() wrote, each as estimator_from_container reads it.
  static std::unique_ptr<PerJointEstimator> from_container(const ModelContainer& container, const std::string& what);

 private:
  std::vector<std::shared_ptr<const Estimator>> models_;
  std::vector<int> joint_model_;
};

}  // namespace gipdyn
