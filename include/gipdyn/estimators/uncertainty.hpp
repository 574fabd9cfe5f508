#pragma once
// How sure an estimator is of its torque: the latent (noise-free) predictive
// standard deviation at a state, and the noise it learned on each joint. A
// measured torque may then lie about sqrt(latent^2 + noise^2) from the
// prediction with nothing outside the model acting on the robot (contact
// detection, sensing/contact_detection.hpp). The GP estimators and lip have
// both (EstimatorSpec::predictive_variance); the others have neither.
#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/estimators/estimator.hpp"

namespace gipdyn {

// Whether a model gives a predictive standard deviation: Estimator::gives_uncertainty().
// The names of every estimator that gives one, in the table's order.
std::vector<std::string> uncertainty_estimator_names();

// Per joint, the standard deviation of the noise the estimator learned, in
// torque units; cheap (no factorisation). Throws gipdyn::Error as
// TorqueUncertainty does for estimators without one.
Eigen::VectorXd learned_noise_std(const Estimator& estimator);

// Read-only once made; the estimator must outlive it. It holds a copy of the estimator able to give
// variances: a loaded GP model computes each joint's Cholesky factor here
// (O(N^3) per joint), a lip model the factor of its (N n) x (N n) training
// covariance (O((N n)^3)); a freshly trained GP model shares the one it kept.
class TorqueUncertainty {
 public:
  // Throws gipdyn::Error naming the estimators that have one, for those that do not.
  explicit TorqueUncertainty(const Estimator& estimator);
  ~TorqueUncertainty();
  TorqueUncertainty(TorqueUncertainty&&) noexcept;
  TorqueUncertainty& operator=(TorqueUncertainty&&) noexcept;

  int num_joints() const { return static_cast<int>(noise_std_.size()); }
  // rows x n: the latent predictive standard deviation at every row of X (rows x 3n), torque units.
  Eigen::MatrixXd latent_std(const Eigen::Ref<const Eigen::MatrixXd>& X) const;
  // Per joint, the learned noise's standard deviation, torque units.
  const Eigen::VectorXd& noise_std() const { return noise_std_; }

 private:
  struct Source;
  std::unique_ptr<Source> source_;
  Eigen::VectorXd noise_std_;
};

}  // namespace gipdyn
