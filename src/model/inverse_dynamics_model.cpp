#include "gipdyn/model/inverse_dynamics_model.hpp"

#include <algorithm>
#include <cmath>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/detail/rigid_body_queries.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/floating_point.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

OutputScaling parse_output_scaling(const std::string& name) {
  if (name == "none") return OutputScaling::None;
  if (name == "center") return OutputScaling::Center;
  if (name == "standardize") return OutputScaling::Standardize;
  throw Error("GpOptions::scaling '" + name + "' is unknown; choose none, center or standardize");
}

std::string to_string(OutputScaling s) {
  switch (s) {
    case OutputScaling::None: return "none";
    case OutputScaling::Center: return "center";
    case OutputScaling::Standardize: return "standardize";
  }
  return "none";
}

InverseDynamicsModel::InverseDynamicsModel(const JointTypes& joints, std::string kernel_name, Eigen::MatrixXd X,
                                           std::vector<GpRegressor> gps, OutputScaling scaling,
                                           Eigen::VectorXd y_offset, Eigen::VectorXd y_scale, RobotPrior prior,
                                           std::vector<MeanFunction> means, std::vector<JointReport> training,
                                           Eigen::Index data_rows)
    : joints_(joints),
      features_(joints),
      kernel_name_(std::move(kernel_name)),
      X_(std::move(X)),
      data_rows_(data_rows > 0 ? data_rows : X_.rows()),
      gps_(std::move(gps)),
      means_(std::move(means)),
      scaling_(scaling),
      y_offset_(std::move(y_offset)),
      y_scale_(std::move(y_scale)),
      prior_(std::move(prior)),
      training_(std::move(training)) {
  const int n = joints_.size();
  if (X_.cols() != 3 * n) throw Error("model: training inputs must have 3n columns");
  if (static_cast<int>(gps_.size()) != n || y_offset_.size() != n || y_scale_.size() != n)
    throw Error("model: one GP, offset and scale per joint are required");
  if (means_.empty()) means_.assign(static_cast<size_t>(n), MeanFunction());
  if (!training_.empty() && static_cast<int>(training_.size()) != n)
    throw Error("model: one training report per joint (or none) is required");
  if (static_cast<int>(means_.size()) != n) throw Error("model: one mean function per joint is required");
  for (const auto& m : means_)
    if (m.kind() != means_.front().kind() || (m.kind() == MeanKind::Linear && m.input_dim() != 3 * n))
      throw Error("model: every joint needs the same kind of mean function on the 3n inputs");
  for (const auto& gp : gps_) {
    if (gp.alpha().size() != X_.rows()) throw Error("model: alpha must have one entry per training sample");
    if (gp.is_sparse() != gps_.front().is_sparse()) throw Error("model: either every joint's GP is sparse or none");
  }
  if (data_rows_ < X_.rows()) throw Error("model: fewer data rows than training inputs");
  Z_ = features_.compute(X_);
  // The fused single-query path is chosen here, by kernel name, once.
  if (is_gip_kernel(kernel_name_))
    for (int j = 0; j < n; ++j) {
      gip_kernels_.push_back(make_gip_kernel(kernel_name_, features_, j));
      gip_kernels_.back().set_log_params(gps_[static_cast<size_t>(j)].kernel().log_params());
    }
}

double InverseDynamicsModel::noise_variance(int j) const {
  const double scale = y_scale_(j);
  return std::exp(gps_[static_cast<size_t>(j)].log_noise_variance()) * scale * scale;
}

std::vector<std::pair<std::string, double>> InverseDynamicsModel::hyperparameters(int j) const {
  const GpRegressor& gp = joint_gp(j);
  const auto names = gp.kernel().param_names();
  const Eigen::VectorXd p = gp.kernel().log_params();
  std::vector<std::pair<std::string, double>> out;
  for (size_t k = 0; k < names.size(); ++k) out.emplace_back(names[k], std::exp(p(static_cast<Eigen::Index>(k))));
  out.emplace_back("noise.variance", std::exp(gp.log_noise_variance()));
  const MeanFunction& mean = joint_mean(j);
  const auto mean_names = mean.param_names();
  for (size_t k = 0; k < mean_names.size(); ++k) out.emplace_back(mean_names[k], mean.params()(static_cast<Eigen::Index>(k)));
  return out;
}

Eigen::MatrixXd InverseDynamicsModel::predict(const Eigen::Ref<const Eigen::MatrixXd>& X) const {
  Eigen::MatrixXd mean;
  predict(X, mean, nullptr);
  return mean;
}

void InverseDynamicsModel::predict(const Eigen::Ref<const Eigen::MatrixXd>& X, Eigen::MatrixXd& mean,
                                   Eigen::MatrixXd* stddev) const {
  if (X.cols() != 3 * num_joints())
    throw Error("inputs have " + std::to_string(X.cols()) + " columns; this " + joints_.str() + " model needs " +
                std::to_string(3 * num_joints()) + " (q, qd, qdd)");
  if (stddev && !has_variance())
    throw Error("this model has no Cholesky factors for predictive variance; use its with_variance() copy");
  use_single_threaded_blas();
  const FlushSubnormalsToZero fast_floats;
  const Eigen::MatrixXd Zs = features_.compute(X);
  mean.resize(X.rows(), num_joints());
  if (stddev) stddev->resize(X.rows(), num_joints());
  Eigen::VectorXd m, v;
  Eigen::MatrixXd H;  // the mean's basis: the same for every joint
  if (mean_kind() != MeanKind::Zero) means_.front().basis(X, H);
  for (int j = 0; j < num_joints(); ++j) {
    gps_[static_cast<size_t>(j)].predict_mean(Zs, Z_, m);
    if (H.cols() > 0) m.noalias() += H * means_[static_cast<size_t>(j)].params();
    mean.col(j) = (y_offset_(j) + y_scale_(j) * m.array()).matrix();
    if (stddev) {
      gps_[static_cast<size_t>(j)].predict_variance(Zs, Z_, v);
      stddev->col(j) = (y_scale_(j) * v.array().sqrt()).matrix();
    }
  }
}

bool InverseDynamicsModel::has_variance() const {
  for (const auto& gp : gps_)
    if (!gp.has_factor()) return false;
  return true;
}

InverseDynamicsModel InverseDynamicsModel::with_variance() const {
  use_single_threaded_blas();
  const FlushSubnormalsToZero fast_floats;
  InverseDynamicsModel copy = *this;
  GpWorkspace ws;
  for (int j = 0; j < num_joints(); ++j) {
    GpRegressor& gp = copy.gps_[static_cast<size_t>(j)];
    if (gp.has_factor()) continue;
    const CholeskyResult r = gp.compute_factor(Z_, ws);
    if (!r.ok()) throw Error("joint " + std::to_string(j + 1) + ": cannot compute predictive variance: " + r.message);
  }
  return copy;
}

Eigen::MatrixXd InverseDynamicsModel::training_targets() const {
  if (is_sparse()) throw Error("a sparse model keeps its inducing rows, not its training targets");
  if (!has_variance()) throw Error("training_targets needs the Cholesky factors; use the with_variance() copy");
  Eigen::MatrixXd H;
  if (mean_kind() != MeanKind::Zero) means_.front().basis(X_, H);
  Eigen::MatrixXd Y(X_.rows(), num_joints());
  for (int j = 0; j < num_joints(); ++j) {
    Eigen::VectorXd r = gps_[static_cast<size_t>(j)].fitted_targets();
    if (H.cols() > 0) r.noalias() += H * means_[static_cast<size_t>(j)].params();
    Y.col(j) = (y_offset_(j) + y_scale_(j) * r.array()).matrix();
  }
  return Y;
}

namespace {

// Checked before any work (a copy or the factors can cost O(N^3)).
void check_new_samples(const InverseDynamicsModel& m, const Eigen::Ref<const Eigen::MatrixXd>& Xnew,
                       const Eigen::Ref<const Eigen::MatrixXd>& Ynew, Eigen::Index window) {
  const int n = m.num_joints();
  if (m.is_sparse() && window > 0)
    throw Error("window: a sparse model keeps only its " + std::to_string(m.num_training_samples()) +
                " inducing rows, not the rows to drop; use window 0 (keep every row) or an exact GP model");
  if (Xnew.cols() != 3 * n || Ynew.cols() != n)
    throw Error("new samples need " + std::to_string(3 * n) + " input and " + std::to_string(n) +
                " torque columns for this " + m.joints().str() + " model; got " + std::to_string(Xnew.cols()) + " and " +
                std::to_string(Ynew.cols()));
  if (Xnew.rows() != Ynew.rows())
    throw Error("new samples: " + std::to_string(Xnew.rows()) + " input rows but " + std::to_string(Ynew.rows()) +
                " torque rows");
  if (!Xnew.allFinite() || !Ynew.allFinite()) throw Error("new samples contain NaN or Inf");
  require_plausible_inputs(Xnew, m.joints(), "new sample input");
  if (window < 0) throw Error("window must be >= 0 (0: keep every row)");
  if (window > 0 && window < kMinTrainingRows)
    throw Error("window must be 0 or at least " + std::to_string(kMinTrainingRows) + " rows");
}

}  // namespace

InverseDynamicsModel InverseDynamicsModel::updated(const Eigen::Ref<const Eigen::MatrixXd>& Xnew,
                                                   const Eigen::Ref<const Eigen::MatrixXd>& Ynew,
                                                   Eigen::Index window) const& {
  check_new_samples(*this, Xnew, Ynew, window);
  InverseDynamicsModel copy = has_variance() ? *this : with_variance();
  copy.update_in_place(Xnew, Ynew, window);
  return copy;
}

InverseDynamicsModel InverseDynamicsModel::updated(const Eigen::Ref<const Eigen::MatrixXd>& Xnew,
                                                   const Eigen::Ref<const Eigen::MatrixXd>& Ynew,
                                                   Eigen::Index window) && {
  check_new_samples(*this, Xnew, Ynew, window);
  if (!has_variance()) *this = with_variance();
  update_in_place(Xnew, Ynew, window);
  return std::move(*this);
}

void InverseDynamicsModel::update_in_place(const Eigen::Ref<const Eigen::MatrixXd>& Xnew,
                                           const Eigen::Ref<const Eigen::MatrixXd>& Ynew, Eigen::Index window) {
  const int n = num_joints();
  // A window smaller than the new batch keeps only the newest of the new rows.
  const Eigen::Index skip = window > 0 ? std::max<Eigen::Index>(0, Xnew.rows() - window) : 0;
  const Eigen::Index added = Xnew.rows() - skip;
  const Eigen::Index total = X_.rows() + added;
  const Eigen::Index drop = window > 0 ? std::min<Eigen::Index>(X_.rows(), std::max<Eigen::Index>(0, total - window)) : 0;

  use_single_threaded_blas();
  if (is_sparse()) {  // the inducing rows stay; the new rows enter through A and alpha
    const Eigen::MatrixXd Znew = features_.compute(Xnew);
    for (int j = 0; j < n; ++j) {
      const Eigen::VectorXd fresh = ((Ynew.col(j).array() - y_offset_(j)) / y_scale_(j)).matrix();
      const CholeskyResult r = gps_[static_cast<size_t>(j)].add_rows_sparse(Z_, Znew, fresh);
      if (!r.ok()) throw Error("joint " + std::to_string(j + 1) + ": " + r.message);
    }
    data_rows_ += Xnew.rows();
    return;
  }
  const Eigen::Index kept = X_.rows() - drop;
  Eigen::MatrixXd X(kept + added, 3 * n);
  X << X_.bottomRows(kept), Xnew.bottomRows(added);
  // Only the new rows need their features computed.
  Eigen::MatrixXd Z(kept + added, Z_.cols());
  Z << Z_.bottomRows(kept), features_.compute(Xnew.bottomRows(added));
  Eigen::MatrixXd Hnew;
  if (mean_kind() != MeanKind::Zero) means_.front().basis(Xnew.bottomRows(added), Hnew);
  for (int j = 0; j < n; ++j) {
    GpRegressor& gp = gps_[static_cast<size_t>(j)];
    Eigen::VectorXd y(kept + added);
    y.head(kept) = gp.fitted_targets().tail(kept);
    Eigen::VectorXd fresh = ((Ynew.col(j).tail(added).array() - y_offset_(j)) / y_scale_(j)).matrix();
    if (Hnew.cols() > 0) fresh.noalias() -= Hnew * means_[static_cast<size_t>(j)].params();
    y.tail(added) = fresh;
    const CholeskyResult r = gp.update(drop, Z, added, y);
    if (!r.ok()) throw Error("joint " + std::to_string(j + 1) + ": " + r.message);
  }
  X_ = std::move(X);
  Z_ = std::move(Z);
  data_rows_ = X_.rows();
}

PredictionWorkspace::PredictionWorkspace(const InverseDynamicsModel& model)
    : model_(&model),
      z_(model.features().feature_dim()),
      krow_(model.num_training_samples()),
      v_(model.num_training_samples()),
      f_(model.num_joints()),
      x_(model.features().input_dim()),
      column_(model.num_joints()) {
  use_single_threaded_blas();
  for (int j = 0; j < static_cast<int>(model.gip_kernels().size()); ++j) {
    gip_kernels_.push_back(&model.gip_kernels()[static_cast<size_t>(j)]);
    alphas_.push_back(&model.joint_gp(j).alpha());
  }
  if (!gip_kernels_.empty()) coeff_.resize(gip_kernels_.front()->affine_size(), model.num_joints());
  if (gip_kernels_.empty()) {
    mean_plans_.resize(static_cast<size_t>(model.num_joints()));
    for (int j = 0; j < model.num_joints(); ++j)
      model.joint_gp(j).kernel().plan_mean(model.training_features(), model.joint_gp(j).alpha(),
                                           mean_plans_[static_cast<size_t>(j)]);
  }
  // Warm up every buffer the kernels use, so later calls do not allocate.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(model.features().input_dim());
  Eigen::VectorXd tau(model.num_joints());
  predict(x.data(), tau.data());
}

void PredictionWorkspace::predict(const double* x, double* tau) {
  const FlushSubnormalsToZero fast_floats;  // floating_point.hpp; bench/RESULTS.md times a real-log RBF model
  const InverseDynamicsModel& m = *model_;
  const Eigen::MatrixXd& Z = m.training_features();
  m.features().compute_row(x, z_.data());
  if (!gip_kernels_.empty()) {
    GipKernel::dot_rows(gip_kernels_, alphas_, z_.data(), Z, f_, scratch_);
  } else {
    for (int j = 0; j < m.num_joints(); ++j) {
      const GpRegressor& gp = m.joint_gp(j);
      f_(j) = gp.kernel().mean_one(z_.data(), Z, gp.alpha(), mean_plans_[static_cast<size_t>(j)], krow_, scratch_);
    }
  }
  for (int j = 0; j < m.num_joints(); ++j)
    tau[j] = m.output_offset()(j) + m.output_scale()(j) * (f_(j) + m.joint_mean(j).evaluate_one(x));
}

void PredictionWorkspace::predict_from_coefficients(const double* x, double* tau) {
  const InverseDynamicsModel& m = *model_;
  m.features().compute_row(x, z_.data());
  for (int j = 0; j < m.num_joints(); ++j)
    tau[j] = m.output_offset()(j) +
             m.output_scale()(j) * (gip_kernels_[static_cast<size_t>(j)]->affine_value(coeff_.col(j), z_.data()) +
                                    m.joint_mean(j).evaluate_one(x));
}

void PredictionWorkspace::rigid_body_terms(const double* q, const double* qd, double* gravity, double* M,
                                           double* bias) {
  const FlushSubnormalsToZero fast_floats;
  const InverseDynamicsModel& m = *model_;
  const int n = m.num_joints();
  const bool fused = !gip_kernels_.empty();
  if (fused) {  // the coefficients at (q, 0, 0): only the positions' features matter to them
    x_.setZero();
    x_.head(n) = Eigen::Map<const Eigen::VectorXd>(q, n);
    m.features().compute_row(x_.data(), z_.data());
    GipKernel::affine_coefficients(gip_kernels_, alphas_, z_.data(), m.training_features(), coeff_, scratch_);
  }
  detail::rigid_body_terms_by_queries(n, q, qd, x_.data(), column_.data(), gravity, M, bias,
                                      [&](const double* x, double* tau) {
                                        fused ? predict_from_coefficients(x, tau) : predict(x, tau);
                                      });
}

void PredictionWorkspace::predict(const double* x, double* tau, double* stddev) {
  const InverseDynamicsModel& m = *model_;
  if (!m.has_variance())
    throw Error("this model has no Cholesky factors for predictive variance; use its with_variance() copy");
  const FlushSubnormalsToZero fast_floats;
  const Eigen::MatrixXd& Z = m.training_features();
  m.features().compute_row(x, z_.data());
  const int dim = m.features().feature_dim();
  for (int j = 0; j < m.num_joints(); ++j) {
    const GpRegressor& gp = m.joint_gp(j);
    const double f = gp.predict_mean_one(z_.data(), Z, krow_, scratch_) + m.joint_mean(j).evaluate_one(x);
    tau[j] = m.output_offset()(j) + m.output_scale()(j) * f;
    stddev[j] = m.output_scale()(j) * std::sqrt(gp.predict_variance_one(z_.data(), dim, krow_, v_, scratch_));
  }
}

}  // namespace gipdyn
