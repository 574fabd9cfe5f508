#include "gipdyn/model/update_check.hpp"

#include <cmath>
#include <cstdio>
#include <optional>

#include "gipdyn/error.hpp"

namespace gipdyn {
namespace {

constexpr double kLogTwoPi = 1.8378770664093453;

double log_density(double residual, double variance) {
  return -0.5 * (kLogTwoPi + std::log(variance) + residual * residual / variance);
}

}  // namespace

std::vector<int> UpdateCheck::misfit_joints() const {
  std::vector<int> joints;
  for (Eigen::Index j = 0; j < new_rows_lpd.size(); ++j)
    if (own_rows_lpd(j) - new_rows_lpd(j) > tolerance) joints.push_back(static_cast<int>(j));
  return joints;
}

std::string UpdateCheck::brief_report() const {
  std::string out = "log predictive density a row (nats), new rows against the model's own rows left out one at a time:\n";
  char buf[160];
  for (Eigen::Index j = 0; j < new_rows_lpd.size(); ++j) {
    const double gap = own_rows_lpd(j) - new_rows_lpd(j);
    std::snprintf(buf, sizeof buf, " joint %ld: %.3g against %.3g (%s%.3g)%s\n", static_cast<long>(j + 1),
                  new_rows_lpd(j), own_rows_lpd(j), gap > 0 ? "-" : "+", std::abs(gap),
                  gap > tolerance ? ": the hyperparameters no longer fit" : "");
    out += buf;
  }
  return out;
}

std::string UpdateCheck::warning() const {
  const std::vector<int> misfit = misfit_joints();
  if (misfit.empty()) return "";
  std::string joints, gaps;
  char buf[32];
  for (size_t k = 0; k < misfit.size(); ++k) {
    const int j = misfit[k];
    joints += (k ? ", " : "") + std::to_string(j + 1);
    std::snprintf(buf, sizeof buf, "%s%.3g", k ? ", " : "", own_rows_lpd(j) - new_rows_lpd(j));
    gaps += buf;
  }
  return "the new rows of joint(s) " + joints + " are " + gaps +
         " nats a row less likely than the model's own rows: the hyperparameters, learned on other motions, no "
         "longer fit them, and conditioning on them with those hyperparameters can make the model worse";
}

UpdateCheck check_update(const InverseDynamicsModel& model, const Eigen::Ref<const Eigen::MatrixXd>& X_new,
                         const Eigen::Ref<const Eigen::MatrixXd>& Y_new, double tolerance) {
  if (model.is_sparse())
    throw Error("the update check needs an exact GP model: a sparse model's leave-one-out is not that of its data");
  const int n = model.num_joints();
  if (X_new.cols() != 3 * n || Y_new.cols() != n || X_new.rows() != Y_new.rows() || X_new.rows() == 0)
    throw Error("the update check needs new rows of " + std::to_string(3 * n) + " inputs and " + std::to_string(n) +
                " torques, as many of each");
  // The model itself where it has its factors (update_estimator factors it once for the check and the update).
  std::optional<InverseDynamicsModel> factored;
  const InverseDynamicsModel& with_factor = model.has_variance() ? model : factored.emplace(model.with_variance());
  Eigen::MatrixXd mean, latent_std;
  with_factor.predict(X_new, mean, &latent_std);
  UpdateCheck check;
  check.tolerance = tolerance;
  check.new_rows_lpd.resize(n);
  check.own_rows_lpd.resize(n);
  for (int j = 0; j < n; ++j) {
    const GpRegressor& gp = with_factor.joint_gp(j);
    const double scale = with_factor.output_scale()(j);
    const double noise = with_factor.noise_variance(j);
    double sum = 0.0;
    for (Eigen::Index r = 0; r < X_new.rows(); ++r)
      sum += log_density(Y_new(r, j) - mean(r, j), latent_std(r, j) * latent_std(r, j) + noise);
    check.new_rows_lpd(j) = sum / static_cast<double>(X_new.rows());
    // Leave-one-out in the GP's scaled units, then in torque units (a residual scales by `scale`, a variance by its square).
    const Eigen::VectorXd d = gp.inverse_diagonal();
    const Eigen::VectorXd& alpha = gp.alpha();
    sum = 0.0;
    for (Eigen::Index i = 0; i < alpha.size(); ++i)
      sum += log_density(alpha(i) / d(i) * scale, scale * scale / d(i));
    check.own_rows_lpd(j) = sum / static_cast<double>(alpha.size());
  }
  return check;
}

}  // namespace gipdyn
