#include "gipdyn/training_data.hpp"

#include "gipdyn/error.hpp"
#include "gipdyn/joint_types.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <unordered_set>
#include <utility>

namespace gipdyn {

void validate_training_data(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const JointTypes& joints) {
  const int n = joints.size();
  if (X.cols() != 3 * n)
    throw Error("inputs have " + std::to_string(X.cols()) + " columns but joints " + joints.str() + " need " +
                std::to_string(3 * n) + " (q, qd, qdd per joint)");
  if (Y.cols() != n)
    throw Error("torques have " + std::to_string(Y.cols()) + " columns but joints " + joints.str() + " need " +
                std::to_string(n));
  if (X.rows() != Y.rows()) throw Error("inputs and torques have different numbers of rows");
  if (X.rows() < kMinTrainingRows)
    throw Error("only " + std::to_string(X.rows()) + " training rows; at least " + std::to_string(kMinTrainingRows) +
                " are needed");
  if (!X.allFinite() || !Y.allFinite()) throw Error("training data contain NaN or Inf; remove or repair those rows");
  // Finite is not enough: scaling sums squares, and a square of 1e300 is Inf,
  // which turned into a model of nulls that no reader could load.
  for (const auto& [name, M] : {std::pair<const char*, const Eigen::MatrixXd*>{"inputs", &X}, {"torques", &Y}}) {
    Eigen::Index row = 0, col = 0;
    const double largest = M->cwiseAbs().maxCoeff(&row, &col);
    if (largest > kMaxTrainingMagnitude) {
      char value[32];
      std::snprintf(value, sizeof value, "%.3g", (*M)(row, col));
      throw Error(std::string("training ") + name + " column " + std::to_string(col + 1) + " holds " + value +
                  " (row " + std::to_string(row + 1) + "): beyond 1e150 their squares overflow; rescale the data (e.g. "
                  "to N m and rad)");
    }
  }
  require_plausible_inputs(X, joints, "training input");
}

void require_plausible_inputs(const Eigen::Ref<const Eigen::MatrixXd>& X, const JointTypes& joints,
                              const std::string& what) {
  const int n = joints.size();
  if (X.size() == 0 || X.cols() != 3 * n) return;
  Eigen::Index row = 0, col = 0;
  if (X.cwiseAbs().maxCoeff(&row, &col) > kMaxInputMagnitude) {
    char value[32];
    std::snprintf(value, sizeof value, "%.3g", X(row, col));
    throw Error(what + " " + input_column_names(n)[static_cast<size_t>(col)] + " holds " + value +
                " (row " + std::to_string(row + 1) +
                "): no joint position (rad, m), velocity or acceleration reaches 1e6; a corrupted sample, or a log in "
                "other units: remove or repair that row");
  }
}

std::vector<Eigen::Index> constant_step_indices(Eigen::Index rows, Eigen::Index count) {
  std::vector<Eigen::Index> idx;
  if (count <= 0 || count >= rows) {
    for (Eigen::Index r = 0; r < rows; ++r) idx.push_back(r);
    return idx;
  }
  // floor(k rows / count): evenly spread over all rows even when rows / count is
  // not an integer (6340 rows -> 4000 must not keep just the first 4000).
  for (Eigen::Index k = 0; k < count; ++k) idx.push_back(k * rows / count);
  return idx;
}

std::vector<Eigen::Index> constant_step_indices(Eigen::Index rows, Eigen::Index count, Eigen::Index shift,
                                                Eigen::Index shifts) {
  if (shifts < 1 || shift < 0 || shift >= shifts)
    throw Error("constant_step_indices: shift must be in [0, shifts) with shifts >= 1, got shift " +
                std::to_string(shift) + " of " + std::to_string(shifts));
  if (count <= 0 || count >= rows) return constant_step_indices(rows, count);
  std::vector<Eigen::Index> idx;
  // Integer arithmetic: (k shifts + shift) rows / (count shifts) < rows for every k < count.
  for (Eigen::Index k = 0; k < count; ++k) idx.push_back((k * shifts + shift) * rows / (count * shifts));
  return idx;
}

std::vector<Eigen::Index> constant_columns(const Eigen::MatrixXd& X, double tolerance) {
  std::vector<Eigen::Index> out;
  if (X.rows() == 0) return out;
  for (Eigen::Index c = 0; c < X.cols(); ++c) {
    const double lo = X.col(c).minCoeff(), hi = X.col(c).maxCoeff();
    if (hi - lo <= tolerance * (1.0 + X.col(c).cwiseAbs().maxCoeff())) out.push_back(c);
  }
  return out;
}

std::vector<int> revolute_joints_spanning_turns(const Eigen::MatrixXd& X, const JointTypes& joints) {
  std::vector<int> out;
  if (X.rows() == 0 || X.cols() < joints.size()) return out;
  const double two_turns = 4.0 * M_PI;
  for (int j = 0; j < joints.size(); ++j)
    if (joints.is_revolute(j) && X.col(j).maxCoeff() - X.col(j).minCoeff() > two_turns) out.push_back(j);
  return out;
}

std::vector<std::string> training_input_warnings(const Eigen::MatrixXd& X, const JointTypes& joints,
                                                 const std::string& source) {
  std::vector<std::string> out;
  const int n = joints.size();
  if (X.rows() == 0 || X.cols() != 3 * n) return out;
  const std::vector<std::string> names = input_column_names(n);
  const std::vector<Eigen::Index> constant = constant_columns(X);
  const auto is_constant = [&](Eigen::Index c) { return std::count(constant.begin(), constant.end(), c) > 0; };
  // A joint that never moves (locked, or out of the motion) is one line, not three.
  std::vector<std::ptrdiff_t> still;
  for (int j = 0; j < n; ++j)
    if (is_constant(j) && is_constant(n + j) && is_constant(2 * n + j)) still.push_back(j);
  std::vector<std::string> constant_names;
  for (Eigen::Index c : constant)
    if (std::count(still.begin(), still.end(), c % n) == 0) constant_names.push_back(names[static_cast<size_t>(c)]);
  if (!still.empty())
    out.push_back("joint(s) " + joint_numbers(still) + " never move in " + source +
                  " (q, qd and qdd constant: a locked joint?): the model cannot learn how the torque depends on them");
  if (!constant_names.empty())
    out.push_back("column(s) " + joined(constant_names) + " of " + source +
                  " are constant: the model cannot learn how the torque depends on them");
  for (int j : revolute_joints_spanning_turns(X, joints)) {
    char span[32];
    std::snprintf(span, sizeof span, "%.4g", X.col(j).maxCoeff() - X.col(j).minCoeff());
    out.push_back("column " + names[static_cast<size_t>(j)] + " of " + source + " spans " + span +
                  " rad, more than two turns of a revolute joint: if the data are in degrees, convert q, qd and qdd "
                  "to radians (the kernels see cos q and sin q)");
  }
  return out;
}

Eigen::Index count_shared_rows(const Eigen::MatrixXd& train, const Eigen::MatrixXd& test) {
  if (train.cols() != test.cols()) return 0;
  // Row-major copies make each row one contiguous run of bytes to compare.
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const RowMajor a = train, b = test;
  const size_t width = sizeof(double) * static_cast<size_t>(a.cols());
  std::unordered_set<std::string> rows;
  for (Eigen::Index r = 0; r < a.rows(); ++r)
    rows.emplace(reinterpret_cast<const char*>(a.row(r).data()), width);
  Eigen::Index shared = 0;
  for (Eigen::Index r = 0; r < b.rows(); ++r)
    shared += rows.count(std::string(reinterpret_cast<const char*>(b.row(r).data()), width)) > 0;
  return shared;
}

InputBox InputBox::of(const Eigen::MatrixXd& X) {
  if (X.rows() == 0) throw Error("InputBox: no training rows");
  return {X.colwise().minCoeff().transpose(), X.colwise().maxCoeff().transpose()};
}

namespace {

// Applies f(row, column, lo, hi) to every checked column; returns the rows where f reported a change.
template <class F>
Eigen::Index for_checked_columns(const InputBox& box, const Eigen::MatrixXd& X, const JointTypes& joints,
                                 double margin, F&& f) {
  const int n = joints.size();
  if (X.cols() != 3 * n || box.lower.size() != X.cols())
    throw Error("InputBox: the inputs have " + std::to_string(X.cols()) + " columns; " + joints.str() +
                " inputs (q, qd, qdd) need " + std::to_string(3 * n));
  if (!(margin >= 0.0)) throw Error("InputBox: margin must be >= 0 (a fraction of each column's training range)");
  Eigen::Index changed = 0;
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    bool any = false;
    for (Eigen::Index c = 0; c < X.cols(); ++c) {
      if (c < n && joints.is_revolute(static_cast<int>(c))) continue;
      const double pad = margin * (box.upper(c) - box.lower(c));
      any |= f(r, c, box.lower(c) - pad, box.upper(c) + pad);
    }
    changed += any ? 1 : 0;
  }
  return changed;
}

}  // namespace

Eigen::Index InputBox::rows_outside(const Eigen::MatrixXd& X, const JointTypes& joints, double margin) const {
  return for_checked_columns(*this, X, joints, margin, [&](Eigen::Index r, Eigen::Index c, double lo, double hi) {
    return X(r, c) < lo || X(r, c) > hi;
  });
}

Eigen::Index InputBox::saturate(Eigen::MatrixXd& X, const JointTypes& joints, double margin) const {
  return for_checked_columns(*this, X, joints, margin, [&](Eigen::Index r, Eigen::Index c, double lo, double hi) {
    const double v = std::clamp(X(r, c), lo, hi);
    const bool moved = v != X(r, c);
    X(r, c) = v;
    return moved;
  });
}

std::string extrapolation_warning(const InputBox& box, const Eigen::MatrixXd& X, const JointTypes& joints,
                                  const std::string& source, double margin) {
  Eigen::Index farthest_column = -1;
  double farthest = 0.0;  // in training ranges beyond the widened box
  const Eigen::Index outside =
      for_checked_columns(box, X, joints, margin, [&](Eigen::Index r, Eigen::Index c, double lo, double hi) {
        const double range = box.upper(c) - box.lower(c);
        const double beyond = std::max(lo - X(r, c), X(r, c) - hi);
        if (beyond <= 0.0) return false;
        const double in_ranges = range > 0.0 ? beyond / range : std::numeric_limits<double>::infinity();
        if (in_ranges > farthest) farthest = in_ranges, farthest_column = c;
        return true;
      });
  if (outside == 0) return "";
  const std::string column = input_column_names(joints.size())[static_cast<size_t>(farthest_column)];
  char reach[64];
  if (std::isfinite(farthest))
    std::snprintf(reach, sizeof reach, "%.2g training ranges beyond it", farthest);
  else
    std::snprintf(reach, sizeof reach, "constant in training");
  return std::to_string(outside) + " of " + std::to_string(X.rows()) + " rows of " + source +
         " lie outside the box of the model's training inputs (velocities, accelerations and prismatic positions, "
         "widened by " + std::to_string(static_cast<int>(std::lround(100.0 * margin))) + " % of each range), " +
         column + " farthest (" + reach + "): predictions there are extrapolation (a gip model carries its "
         "polynomial into them, which holds for rigid-body dynamics but not for friction or other unmodelled "
         "effects; rbf and gip-envelope return to the mean); to trust them, train on a motion that covers these "
         "states";
}

}  // namespace gipdyn
