#pragma once
// Whether a model's hyperparameters still fit new rows. An online update
// conditions on new rows with the hyperparameters fixed; where those rows come
// from motions the hyperparameters were not learned on (a model trained on a
// short stretch, then given the rest of the log), conditioning on them can make
// the model worse. The check compares how likely the new rows are under the
// model with how likely its own rows are, each left out in turn: a calibrated
// model finds both alike.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"

namespace gipdyn {

// New rows this many nats a row less likely than the model's own are a misfit:
// a Gaussian residual about 2.2 times the predicted standard deviation.
inline constexpr double kUpdateMisfitNats = 2.0;

struct UpdateCheck {
  // Per joint, in nats a row: the mean log predictive density of the new rows
  // (mean and variance, the noise included), and of the model's own rows each
  // predicted from the others (leave-one-out).
  Eigen::VectorXd new_rows_lpd, own_rows_lpd;
  double tolerance = kUpdateMisfitNats;

  // Joints (0-based) whose new rows are more than `tolerance` nats a row less likely than the model's own.
  std::vector<int> misfit_joints() const;
  bool passed() const { return misfit_joints().empty(); }
  // One line per joint: both densities and their gap.
  std::string brief_report() const;
  // "" where it passed; else one line naming the joints and the gaps.
  std::string warning() const;
};

// Throws gipdyn::Error for a sparse model (its leave-one-out is not that of
// the data it was trained on), for rows of another width and for a kernel
// matrix that is no longer positive definite. O(N^3) per joint once (the
// factor and its inverse's diagonal), then O(N) a new row.
UpdateCheck check_update(const InverseDynamicsModel& model, const Eigen::Ref<const Eigen::MatrixXd>& X_new,
                         const Eigen::Ref<const Eigen::MatrixXd>& Y_new, double tolerance = kUpdateMisfitNats);

}  // namespace gipdyn
