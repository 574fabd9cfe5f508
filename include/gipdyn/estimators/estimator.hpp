#pragma once
// Every way gipdyn learns inverse dynamics, behind one interface: predict
// torques, describe what was learned, become a model file's contents. The
// estimators are listed by name in estimator_registry.hpp, fitted by
// fit_estimator (fit_estimator.hpp) and saved and loaded by estimator_file.hpp.
#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <string>

#include "gipdyn/io/model_container.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn {

class InverseDynamicsModel;

class Estimator {
 public:
  virtual ~Estimator() = default;
  virtual std::string name() const = 0;
  virtual const JointTypes& joints() const = 0;
  // Torques (M x n) for every row of X (M x 3n: q, qd, qdd).
  virtual Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const = 0;
  // The estimator as a model file's contents (header + arrays); "estimator"
  // in the header names the family (gp, fe, nn) that estimator_file.hpp reads back.
  virtual ModelContainer to_container() const = 0;
  // What was learned, for reports: hyperparameters, noise, weights count...
  virtual nlohmann::json summary() const = 0;
  // The GP model behind a GP estimator (predictive variances, hyperparameters);
  // nullptr for the others.
  virtual const InverseDynamicsModel* gp_model() const { return nullptr; }
};

}  // namespace gipdyn
