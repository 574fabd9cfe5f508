#pragma once
// Every way gipdyn learns inverse dynamics, behind one interface: predict
// torques, describe what was learned, become a model file's contents. The
// estimators are listed by name in estimator_registry.hpp, fitted by
// fit_estimator (fit_estimator.hpp) and saved and loaded by estimator_file.hpp.
#include <Eigen/Dense>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn {

// The model file container (io/detail/model_container.hpp, docs/model-format.md).
struct ModelContainer;

class InverseDynamicsModel;

// One query at a time, for control loops: bound to one estimator (which must
// outlive it), used by one thread. Made by Estimator::make_query_workspace.
class QueryWorkspace {
 public:
  // num_joints sizes the buffers of the default rigid_body_terms(): no allocation after construction.
  explicit QueryWorkspace(int num_joints);
  virtual ~QueryWorkspace() = default;
  // x: 3n inputs (q, qd, qdd); tau: n outputs.
  virtual void predict(const double* x, double* tau) = 0;
  // Whether predict() runs without a heap allocation once the workspace exists.
  virtual bool allocation_free() const = 0;
  // The rigid-body terms of a model whose torque is affine in qdd (physics.hpp, require_physics), at one state:
  // gravity g(q) = f(q, 0, 0) (n values); M, the inertia matrix as the joints' models learn its rows,
  // M(i, j) = f_i(q, 0, e_j) - g_i(q) (n x n, row-major, not symmetrised); and, where bias is not null,
  // f(q, qd, 0) (n values: Coriolis, gravity and friction). The default runs n + 2 predict() calls; a GIP
  // model's workspace answers all of them from one pass over its training rows.
  virtual void rigid_body_terms(const double* q, const double* qd, double* gravity, double* M, double* bias);

 private:
  std::vector<double> x_, tau_;  // the default rigid_body_terms()'s query and answer
};

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
  // The single-query path. GP and network estimators give one that never
  // allocates; the default goes through predict() on a one-row matrix.
  virtual std::unique_ptr<QueryWorkspace> make_query_workspace() const;
  // Whether its torque is affine in the accelerations, so that gravity,
  // inertia and Coriolis terms come out of it (physics.hpp); the default: its
  // name's row of the estimator table (EstimatorSpec::rigid_body_terms).
  virtual bool gives_rigid_body_terms() const;
  // Where it gives none, why, as a clause of an error message; the default:
  // its torque is not affine in the accelerations.
  virtual std::string why_no_rigid_body_terms() const;
  // Whether it gives a predictive standard deviation (uncertainty.hpp); the
  // default: its name's row (EstimatorSpec::predictive_variance).
  virtual bool gives_uncertainty() const;

  // How the fit that made this estimator used a teacher: the model file's
  // "teacher" block (docs/model-format.md), written by fit_estimator and kept
  // by model files (estimator_file.hpp); null where no teacher was asked for.
  const nlohmann::json* teaching_record() const { return teaching_record_.get(); }
  // A null record clears it.
  void set_teaching_record(const nlohmann::json& record);
  // How this estimator was chosen among candidates (model_selection.hpp): the
  // model file's "selection" block; null where it was named.
  const nlohmann::json* selection_record() const { return selection_record_.get(); }
  void set_selection_record(const nlohmann::json& record);
  // The options it was trained with (options_record.hpp): the model file's
  // "options" block; null for a model from a file written before it was recorded.
  const nlohmann::json* options_record() const { return options_record_.get(); }
  void set_options_record(const nlohmann::json& record);

 private:
  std::shared_ptr<const nlohmann::json> teaching_record_;
  std::shared_ptr<const nlohmann::json> selection_record_;
  std::shared_ptr<const nlohmann::json> options_record_;
};

}  // namespace gipdyn
