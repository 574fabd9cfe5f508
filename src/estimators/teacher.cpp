#include "gipdyn/estimators/teacher.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

std::string to_string(TeachingMode mode) { return mode == TeachingMode::Always ? "always" : "automatic"; }

void TeacherOptions::validate() const {
  require_known_estimator(name);
  if (estimator_needs_robot(name))
    throw Error("TeacherOptions::name: '" + name + "' needs a nominal robot; a teacher learns from the data alone (lip, gip, ...)");
  if (states < kMinTrainingRows)
    throw Error("TeacherOptions::states must be at least " + std::to_string(kMinTrainingRows) + " (e.g. 2000)");
  if (hyperparameter_rows < 0) throw Error("TeacherOptions::hyperparameter_rows must be >= 0 (0: all rows)");
  if (hyperparameter_rows > 0 && hyperparameter_rows < kMinTrainingRows)
    throw Error("TeacherOptions::hyperparameter_rows must be 0 or at least " + std::to_string(kMinTrainingRows));
  if (student_hyperparameter_rows < 0)
    throw Error("TeacherOptions::student_hyperparameter_rows must be >= 0 (0: all drawn states)");
  if (student_hyperparameter_rows > 0 && student_hyperparameter_rows < kMinTrainingRows)
    throw Error("TeacherOptions::student_hyperparameter_rows must be 0 or at least " +
                std::to_string(kMinTrainingRows));
  if (automatic_max_log_values < 0)
    throw Error("TeacherOptions::automatic_max_log_values must be >= 0 (rows x joints, e.g. 14000)");
}

bool TeacherOptions::teaches(Eigen::Index rows, Eigen::Index joints) const {
  return mode == TeachingMode::Always || static_cast<long>(rows) * static_cast<long>(joints) <= automatic_max_log_values;
}

SearchSettings TeacherOptions::teacher_search(const SearchSettings& student) const {
  SearchSettings search = student;
  search.hyperparameter_rows = hyperparameter_rows;
  return search;
}

SearchSettings TeacherOptions::student_search(const SearchSettings& student) const {
  SearchSettings search = student;
  if (search.hyperparameter_rows == 0) search.hyperparameter_rows = student_hyperparameter_rows;
  return search;
}

namespace {

// The teacher's MSE on joint j's logged torques over their variance; NaN where
// the logged torque is constant.
double teacher_log_nmse(const Eigen::MatrixXd& Y, const Eigen::VectorXd& teacher_residual_rms, Eigen::Index j) {
  const double variance = column_variance(Y.col(j))(0);
  if (!(variance > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return teacher_residual_rms(j) * teacher_residual_rms(j) / variance;
}

// False where either nMSE is NaN (a joint whose logged torque is constant).
bool student_misses_joint(const TeachingCheck& check, Eigen::Index j) {
  return check.student_nmse(j) - check.teacher_nmse(j) > kTaughtNmseGapWarning &&
         check.student_nmse(j) > kTaughtResidualRatioWarning * check.teacher_nmse(j);
}

}  // namespace

TeachingCheck check_teaching(const Eigen::MatrixXd& Y, const Eigen::VectorXd& teacher_residual_rms,
                             const Eigen::MatrixXd& student_prediction) {
  if (student_prediction.rows() != Y.rows() || student_prediction.cols() != Y.cols() ||
      teacher_residual_rms.size() != Y.cols())
    throw Error("check_teaching: Y, teacher_residual_rms and student_prediction must have the same joints and rows");
  const Accuracy student = compute_accuracy(Y, student_prediction);
  TeachingCheck check;
  check.student_nmse = student.nmse;
  check.teacher_nmse.resize(Y.cols());
  for (Eigen::Index j = 0; j < Y.cols(); ++j) {
    check.teacher_nmse(j) = teacher_log_nmse(Y, teacher_residual_rms, j);
    if (std::isnan(check.teacher_nmse(j))) check.student_nmse(j) = std::numeric_limits<double>::quiet_NaN();
  }
  return check;
}

bool TeachingCheck::passed() const {
  for (Eigen::Index j = 0; j < student_nmse.size(); ++j)
    if (student_misses_joint(*this, j)) return false;
  return true;
}

std::vector<int> TeachingCheck::joints_teacher_far_ahead() const {
  std::vector<int> joints;
  for (Eigen::Index j = 0; j < student_nmse.size(); ++j)  // false for NaN, a joint whose logged torque is constant
    if (student_nmse(j) > kTeacherFarAheadFloor && student_nmse(j) >= kTeacherFarAheadRatio * teacher_nmse(j) &&
        !student_misses_joint(*this, j))
      joints.push_back(static_cast<int>(j));
  return joints;
}

std::string TeachingCheck::warning(const std::string& teacher_name) const {
  std::string joints;
  for (Eigen::Index j = 0; j < student_nmse.size(); ++j) {
    if (!student_misses_joint(*this, j)) continue;
    char buf[96];
    std::snprintf(buf, sizeof buf, "%s%ld (%.3g against %.3g)", joints.empty() ? "" : ", ", static_cast<long>(j + 1),
                  student_nmse(j), teacher_nmse(j));
    joints += buf;
  }
  if (joints.empty()) return "";
  return "the model taught by " + teacher_name + " fits the logged rows far worse than its teacher (nMSE on the log, joint " +
         joints + "): the log's states fill too little of their box for the teacher's torques there to be more than "
         "extrapolation, as on a real robot's log; train without a teacher (e.g. the teacher's kernel " + teacher_name +
         " itself, or " + default_estimator_name() + ")";
}

TeachingSet label_states(const TeacherOptions& options, std::unique_ptr<Estimator> teacher, FitReport teacher_report,
                         const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y) {
  TeachingSet set;
  set.teacher_report = std::move(teacher_report);
  set.teacher = std::move(teacher);
  const Eigen::MatrixXd residual = Y - set.teacher->predict(X);
  set.label_noise_std = (residual.colwise().squaredNorm() / static_cast<double>(X.rows())).cwiseSqrt().transpose();

  const Eigen::RowVectorXd lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  set.X.resize(options.states, X.cols());
  for (Eigen::Index r = 0; r < set.X.rows(); ++r)
    for (Eigen::Index c = 0; c < set.X.cols(); ++c) set.X(r, c) = lo(c) + (hi(c) - lo(c)) * unit(rng);
  set.Y = set.teacher->predict(set.X);
  // A joint whose logged torque never changes (locked, or a dead sensor) tells
  // the teacher nothing but that value; its predictions there differ from it
  // by rounding, which the student would take for a signal of variance 1e-20.
  // Likewise, where the teacher calls nearly all of a joint's logged variance
  // noise (kTeacherNoiseShareForMeanLabels), its torques away from the log are
  // the extrapolation of what it did not learn: the student gets the logged mean.
  set.student_noise_std_floor = set.label_noise_std;
  for (Eigen::Index j = 0; j < Y.cols(); ++j) {
    if (Y.col(j).maxCoeff() == Y.col(j).minCoeff())
      set.Y.col(j).setConstant(Y(0, j));
    else if (teacher_log_nmse(Y, set.label_noise_std, j) >= kTeacherNoiseShareForMeanLabels)
      set.Y.col(j).setConstant(Y.col(j).mean());
    else
      continue;
    set.student_noise_std_floor(j) = 0.0;
  }
  return set;
}

}  // namespace gipdyn
