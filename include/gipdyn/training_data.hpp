#pragma once
// What every estimator asks of its training data, and how rows are thinned.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/joint_types.hpp"

namespace gipdyn {

constexpr int kMinTrainingRows = 5;
// Largest magnitude of a training value: sums of N squares must stay finite.
constexpr double kMaxTrainingMagnitude = 1e150;
// Largest magnitude of a training input: no joint position (rad, m), velocity or
// acceleration reaches it, and one corrupted sample beyond it made the polynomial
// kernels' matrices overflow ("not positive definite even at the start").
constexpr double kMaxInputMagnitude = 1e6;

// Checks shapes (X: N x 3n, Y: N x n), finiteness, magnitudes up to
// kMaxTrainingMagnitude (torques) and kMaxInputMagnitude (inputs) and N >= kMinTrainingRows; throws gipdyn::Error with
// the first problem found.
void validate_training_data(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints);

// Throws gipdyn::Error naming the column and row of X (N x 3n) whose magnitude
// exceeds kMaxInputMagnitude; `what` names X in the message ("training input").
void require_plausible_inputs(const Eigen::Ref<const Eigen::MatrixXd>& X, const JointTypes& joints,
                              const std::string& what);

// Rows floor(k rows / count), k = 0..count-1: `count` rows with a constant
// (possibly fractional) step over the whole range, as the paper subsampled the
// UR10 data. count <= 0 or count >= rows keeps everything.
std::vector<Eigen::Index> constant_step_indices(Eigen::Index rows, Eigen::Index count);
// The shift-th (0 <= shift < shifts) of `shifts` interleaved constant-step
// subsamples: rows floor((k + shift / shifts) rows / count). Different shifts
// give different rows of the same motions, for repeats of a learning curve.
std::vector<Eigen::Index> constant_step_indices(Eigen::Index rows, Eigen::Index count, Eigen::Index shift,
                                                Eigen::Index shifts);

// Columns of X whose values (almost) do not vary: max - min <= tolerance x
// (1 + max |value|). A model cannot learn how the torque depends on them.
std::vector<Eigen::Index> constant_columns(const Eigen::MatrixXd& X, double tolerance = 1e-12);

// Revolute joints (0-based) whose logged positions span more than two turns
// (4 pi rad). A log in degrees is the usual cause: a joint moving 30-300
// degrees spans 30-300 "rad", and the kernels, which see cos q and sin q, find
// no structure in them. A joint that turns without end is the other cause.
std::vector<int> revolute_joints_spanning_turns(const Eigen::MatrixXd& X, const JointTypes& joints);

// One line per problem of the training inputs X (N x 3n) that a user should
// hear about before trusting the model: joints that never move (q, qd and qdd
// constant: one line naming them), other constant columns, revolute positions
// spanning more than two turns. `source` names the inputs in the messages
// ("'log.csv'", "X"). Empty when there is nothing to say.
std::vector<std::string> training_input_warnings(const Eigen::MatrixXd& X, const JointTypes& joints,
                                                 const std::string& source);

// The box the training inputs span: per column of X (q, qd, qdd) its smallest
// and largest value. Polynomial kernels grow without bound outside it;
// saturate() clamps queries into it (docs/results/real-robots.md measures when that pays).
struct InputBox {
  Eigen::VectorXd lower, upper;
  // Throws gipdyn::Error for an empty X.
  static InputBox of(const Eigen::MatrixXd& X);
  // Rows of X with a checked column outside the box widened by margin x (upper - lower)
  // on each side. Revolute positions are not checked: the kernels see them as
  // cos and sin, which are bounded anyway.
  Eigen::Index rows_outside(const Eigen::MatrixXd& X, const JointTypes& joints, double margin) const;
  // Clamps the checked columns into the widened box; returns the rows changed.
  // Throws gipdyn::Error for a negative margin or X of another width.
  Eigen::Index saturate(Eigen::MatrixXd& X, const JointTypes& joints, double margin) const;
};

// "" when every row of X lies in the box of the training inputs widened by
// margin x (upper - lower); else one line saying how many rows of `source` lie
// outside and which column reaches farthest, in training ranges beyond the box.
// Predictions there are extrapolation: polynomial kernels (GIP) carry what
// they learned into it, right as far as they learned rigid-body dynamics and
// wrong for what else the log holds (real logs, docs/results/real-robots.md);
// local kernels (RBF, the envelope) return to the prior mean.
std::string extrapolation_warning(const InputBox& box, const Eigen::MatrixXd& X, const JointTypes& joints,
                                  const std::string& source, double margin = 0.5);

// How many rows of `test` also occur, bit for bit, as rows of `train`.
Eigen::Index count_shared_rows(const Eigen::MatrixXd& train, const Eigen::MatrixXd& test);

}  // namespace gipdyn
