#pragma once
// A trained inverse dynamics model: one independent GP per joint, all sharing
// the same training inputs. The model never changes after construction, so
// one model may serve any number of threads; single-query prediction for
// control loops goes through a PredictionWorkspace (one per thread) that owns
// every mutable buffer.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/features.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/joint_types.hpp"
#include "gipdyn/kernels/gip_kernel.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/model/fit_report.hpp"

namespace gipdyn {

// How each joint's torques are transformed before the GP sees them (undone at prediction).
enum class OutputScaling { None, Center, Standardize };
OutputScaling parse_output_scaling(const std::string& name);  // none | center | standardize
std::string to_string(OutputScaling s);

class InverseDynamicsModel {
 public:
  InverseDynamicsModel() = default;
  // X: training inputs (N x 3n). gps: one fitted GP per joint (alpha set).
  // means: one prior mean per joint in scaled-output units (empty: zero means).
  // training: how each joint's hyperparameters were found (empty when unknown,
  // as for files written before it was recorded). For sparse GPs (every joint's
  // GpRegressor::is_sparse()), X holds the inducing rows and data_rows the
  // number of rows the model was trained on (0: X's rows).
  InverseDynamicsModel(const JointTypes& joints, std::string kernel_name, Eigen::MatrixXd X,
                       std::vector<GpRegressor> gps, OutputScaling scaling, Eigen::VectorXd y_offset,
                       Eigen::VectorXd y_scale, RobotPrior prior = {}, std::vector<MeanFunction> means = {},
                       std::vector<JointReport> training = {}, Eigen::Index data_rows = 0);

  const JointTypes& joints() const { return joints_; }
  int num_joints() const { return joints_.size(); }
  // The rows the GPs are conditioned on: the training rows, or a sparse model's inducing rows.
  int num_training_samples() const { return static_cast<int>(X_.rows()); }
  // The rows the model was trained on (for a sparse model, more than it keeps).
  Eigen::Index num_data_rows() const { return data_rows_; }
  bool is_sparse() const { return !gps_.empty() && gps_.front().is_sparse(); }
  const std::string& kernel_name() const { return kernel_name_; }
  // The nominal robot of model-based kernels (pp, sp); empty otherwise.
  const RobotPrior& robot_prior() const { return prior_; }
  const FeatureMap& features() const { return features_; }
  const Eigen::MatrixXd& training_inputs() const { return X_; }
  const Eigen::MatrixXd& training_features() const { return Z_; }
  const GpRegressor& joint_gp(int j) const { return gps_[static_cast<size_t>(j)]; }
  const MeanFunction& joint_mean(int j) const { return means_[static_cast<size_t>(j)]; }
  MeanKind mean_kind() const { return means_.front().kind(); }
  OutputScaling output_scaling() const { return scaling_; }
  const Eigen::VectorXd& output_offset() const { return y_offset_; }
  const Eigen::VectorXd& output_scale() const { return y_scale_; }
  // One report per joint (stop reason, evaluations, gradient, noise), or empty.
  const std::vector<JointReport>& training_report() const { return training_; }

  // Hyperparameters of joint j as (name, value) with values exp(log-parameter),
  // in the units of the scaled output, then "noise.variance", then the mean
  // coefficients ("mean.*", signed, stored as they are).
  std::vector<std::pair<std::string, double>> hyperparameters(int j) const;
  // Joint j's learned noise variance in torque units squared (the GP's, in scaled units, times the output scale squared).
  double noise_variance(int j) const;

  // Torques for every row of X (M x 3n) -> M x n. With stddev, also the latent
  // predictive standard deviation (needs has_variance()).
  Eigen::MatrixXd predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const;
  void predict(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd& mean, Eigen::MatrixXd* stddev) const;

  // Variances need each joint's Cholesky factor. A trained model keeps them
  // (GpOptions::keep_factor); a loaded one does not. with_variance() returns
  // a copy that has them, computing the missing ones (O(N^3) per joint); it
  // throws gipdyn::Error if a kernel matrix is not positive definite.
  bool has_variance() const;
  InverseDynamicsModel with_variance() const;

  // Online learning with the hyperparameters, prior means and output scaling
  // fixed: a copy whose training set is the current rows plus the rows of
  // (Xnew, Ynew) (torques, N_new x n), keeping the newest `window` rows (0: all).
  // O(N^2) per added or dropped row once every joint has its Cholesky factor
  // (computed first where missing, O(N^3) once); the copy keeps its factors,
  // so further updates stay O(N^2). Throws gipdyn::Error for bad input and for
  // a kernel matrix that is not positive definite with the new rows (naming
  // the joint). Refit the hyperparameters (train_model on training_targets())
  // when the robot has changed more than new data can express.
  // A sparse model conditions on the new rows through its fixed inducing rows:
  // O(M^2) per row, whatever N (GpRegressor::add_rows_sparse); it keeps no
  // rows to drop, so its window must be 0.
  // The && overload (std::move(model).updated(...)) reuses the model's factors
  // instead of copying them: use it in a loop of updates.
  InverseDynamicsModel updated(const Eigen::Ref<const Eigen::MatrixXd>& Xnew,
                               const Eigen::Ref<const Eigen::MatrixXd>& Ynew, Eigen::Index window = 0) const&;
  InverseDynamicsModel updated(const Eigen::Ref<const Eigen::MatrixXd>& Xnew,
                               const Eigen::Ref<const Eigen::MatrixXd>& Ynew, Eigen::Index window = 0) &&;
  // The torques (N x n) the model was fitted to, recovered from its factors
  // (needs has_variance()): with training_inputs(), the data to refit on.
  Eigen::MatrixXd training_targets() const;

  // For GIP-family kernels (gip, gip-friction): the joints' kernels as GipKernel,
  // for the fused all-joints single-query path; empty for other kernels.
  const std::vector<GipKernel>& gip_kernels() const { return gip_kernels_; }

 private:
  void update_in_place(const Eigen::Ref<const Eigen::MatrixXd>& Xnew, const Eigen::Ref<const Eigen::MatrixXd>& Ynew,
                       Eigen::Index window);

  JointTypes joints_ = JointTypes::parse("R");
  FeatureMap features_{joints_};
  std::string kernel_name_;
  Eigen::MatrixXd X_, Z_;
  Eigen::Index data_rows_ = 0;
  std::vector<GpRegressor> gps_;
  std::vector<MeanFunction> means_;
  OutputScaling scaling_ = OutputScaling::None;
  Eigen::VectorXd y_offset_, y_scale_;
  RobotPrior prior_;
  std::vector<JointReport> training_;
  std::vector<GipKernel> gip_kernels_;
};

// Single-query prediction without heap allocation per call (after construction):
// the control-loop path. One workspace per thread; the model must outlive it.
class PredictionWorkspace {
 public:
  explicit PredictionWorkspace(const InverseDynamicsModel& model);
  // x: 3n inputs (q, qd, qdd); tau: n outputs.
  void predict(const double* x, double* tau);
  // Also the latent standard deviation (requires model.has_variance()); one
  // triangular solve per joint, bound by memory bandwidth.
  void predict(const double* x, double* tau, double* stddev);
  // The rigid-body terms at one state, as QueryWorkspace::rigid_body_terms (estimators/estimator.hpp) defines
  // them: g(q) = f(q, 0, 0), M(i, j) = f_i(q, 0, e_j) - g_i(q) (row-major, not symmetrised) and, where bias is
  // not null, f(q, qd, 0). A GIP model's n + 2 queries share q, so one pass over the training rows
  // (GipKernel::affine_coefficients) serves them all; other kernels answer them one by one.
  void rigid_body_terms(const double* q, const double* qd, double* gravity, double* M, double* bias);

 private:
  // tau at x from the GIP kernels' affine coefficients at x's positions (coeff_).
  void predict_from_coefficients(const double* x, double* tau);
  const InverseDynamicsModel* model_;
  Eigen::VectorXd z_, krow_, v_, f_, x_, column_;
  Eigen::MatrixXd coeff_;
  KernelScratch scratch_;
  // Set when the model has GIP kernels: the fused all-joints mean path.
  std::vector<const GipKernel*> gip_kernels_;
  std::vector<const Eigen::VectorXd*> alphas_;
  // Otherwise one mean plan per joint (Kernel::plan_mean), made here: the model is fixed.
  std::vector<MeanPlan> mean_plans_;
};

}  // namespace gipdyn
