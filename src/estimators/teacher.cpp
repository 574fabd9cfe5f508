#include "gipdyn/estimators/teacher.hpp"

#include <random>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_registry.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/training_data.hpp"

namespace gipdyn {

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
}

TrainOptions TeacherOptions::teacher_train_options(const TrainOptions& student) const {
  TrainOptions o;
  o.kernel = name;
  o.optimizer = student.optimizer;
  o.gradient_tolerance_per_row = student.gradient_tolerance_per_row;
  o.restarts = student.restarts;
  o.restart_spread = student.restart_spread;
  o.seed = student.seed;
  o.initial_noise_fraction = student.initial_noise_fraction;
  o.min_noise_fraction = student.min_noise_fraction;
  o.jitter = student.jitter;
  o.threads = student.threads;
  o.hyperparameter_rows = hyperparameter_rows;
  o.keep_factor = false;  // the teacher only predicts means
  return o;
}

TrainOptions TeacherOptions::student_train_options(const TrainOptions& student) const {
  TrainOptions o = student;
  if (o.hyperparameter_rows == 0) o.hyperparameter_rows = student_hyperparameter_rows;
  return o;
}

TeachingSet teach(const TeacherOptions& options, const TrainOptions& student, const Eigen::MatrixXd& X,
                  const Eigen::MatrixXd& Y, const JointTypes& joints, const ProgressCallback& progress) {
  options.validate();
  validate_training_data(X, Y, joints);
  EstimatorOptions teacher;
  teacher.name = options.name;
  teacher.gp = options.teacher_train_options(student);
  teacher.nn.seed = student.seed;
  FitResult fit = fit_estimator(teacher, X, Y, joints, progress);

  TeachingSet set;
  set.teacher_report = std::move(fit.report);
  if (!set.teacher_report.ok()) {
    set.teacher_report.message = "the teacher " + options.name + " failed: " + set.teacher_report.message;
    return set;
  }
  set.teacher = std::move(fit.estimator);

  const Eigen::MatrixXd residual = Y - set.teacher->predict(X);
  set.label_noise_std = (residual.colwise().squaredNorm() / static_cast<double>(X.rows())).cwiseSqrt().transpose();

  const Eigen::RowVectorXd lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  set.X.resize(options.states, X.cols());
  for (Eigen::Index r = 0; r < set.X.rows(); ++r)
    for (Eigen::Index c = 0; c < set.X.cols(); ++c) set.X(r, c) = lo(c) + (hi(c) - lo(c)) * unit(rng);
  set.Y = set.teacher->predict(set.X);
  for (Eigen::Index r = 0; r < set.Y.rows(); ++r)
    for (Eigen::Index j = 0; j < set.Y.cols(); ++j) set.Y(r, j) += set.label_noise_std(j) * normal(rng);
  return set;
}

}  // namespace gipdyn
