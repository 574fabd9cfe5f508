#include "gipdyn/estimators/uncertainty.hpp"

#include <cmath>
#include <optional>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/estimators/lagrangian_estimator.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"

namespace gipdyn {

std::vector<std::string> uncertainty_estimator_names() {
  return estimator_names_where([](const EstimatorSpec& e) { return e.predictive_variance; });
}

// The model that answers: the estimator's own where it already has its
// factors, else a copy that computed them.
struct TorqueUncertainty::Source {
  const InverseDynamicsModel* gp = nullptr;
  const LagrangianEstimator* lip = nullptr;
  std::optional<InverseDynamicsModel> gp_with_factors;
  std::optional<LagrangianEstimator> lip_with_factor;
};

namespace {

const LagrangianEstimator& lagrangian_or_throw(const Estimator& estimator) {
  if (!estimator.gives_uncertainty())
    throw Error("a '" + estimator.name() + "' model gives no predictive standard deviation; these do: " +
                joined(uncertainty_estimator_names()));
  const auto* lip = dynamic_cast<const LagrangianEstimator*>(&estimator);
  if (!lip) throw Error("a '" + estimator.name() + "' model has no predictive standard deviation here");
  return *lip;
}

}  // namespace

Eigen::VectorXd learned_noise_std(const Estimator& estimator) {
  if (const InverseDynamicsModel* model = estimator.gp_model()) {
    Eigen::VectorXd noise(model->num_joints());
    for (int j = 0; j < model->num_joints(); ++j)
      noise(j) = std::sqrt(model->noise_variance(j));
    return noise;
  }
  return lagrangian_or_throw(estimator).noise_variances().cwiseSqrt();
}

TorqueUncertainty::TorqueUncertainty(const Estimator& estimator)
    : source_(std::make_unique<Source>()), noise_std_(learned_noise_std(estimator)) {
  if (const InverseDynamicsModel* model = estimator.gp_model()) {
    if (model->has_variance()) {
      source_->gp = model;
    } else {
      source_->gp_with_factors.emplace(model->with_variance());
      source_->gp = &*source_->gp_with_factors;
    }
    return;
  }
  const LagrangianEstimator& lip = lagrangian_or_throw(estimator);
  if (lip.has_variance()) {
    source_->lip = &lip;
  } else {
    source_->lip_with_factor.emplace(lip.with_variance());
    source_->lip = &*source_->lip_with_factor;
  }
}

TorqueUncertainty::~TorqueUncertainty() = default;
TorqueUncertainty::TorqueUncertainty(TorqueUncertainty&&) noexcept = default;
TorqueUncertainty& TorqueUncertainty::operator=(TorqueUncertainty&&) noexcept = default;

Eigen::MatrixXd TorqueUncertainty::latent_std(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  if (source_->lip) return source_->lip->predict_std(X);
  Eigen::MatrixXd mean, stddev;
  source_->gp->predict(X, mean, &stddev);
  return stddev;
}

}  // namespace gipdyn
