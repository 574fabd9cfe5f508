// Learning from a teacher (estimators/teacher.hpp): the states are drawn from
// the log's box with their seed and labelled with the teacher's torques, the
// student's noise floor is the teacher's residual, and a student trained on
// them predicts a new motion like the teacher does.
#include <gtest/gtest.h>

#include <cmath>

#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/teacher.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

using test::two_link_torques;
using test::two_link_trajectory;

const JointTypes kTwoLink = JointTypes::parse("RR");

// The 2R arm's 15 s motion at dt 0.1 s with torque noise 0.01: a short log.
struct Log {
  Eigen::MatrixXd X, Y;
};
Log short_two_link_log() {
  Log log;
  log.X = two_link_trajectory(150, 0.1, 11);
  log.Y = test::with_noise(two_link_torques(log.X), 0.01, 12);
  return log;
}

double mean_nmse(const Eigen::MatrixXd& truth, const Eigen::MatrixXd& predicted) {
  return compute_accuracy(truth, predicted).nmse.mean();
}

// Which fits the factorisation of an exact GP sets the time of (the long-fit
// notes of train and Python): one rule with fit_estimator's own about teaching.
TEST(Teacher, SaysWhichFitsLearnOnTheLogWithAnExactGp) {
  EstimatorOptions o;
  o.name = "gip";
  TeacherOptions automatic;
  automatic.mode = TeachingMode::Automatic;
  o.teacher = automatic;
  EXPECT_TRUE(teaches(o, 3000, 4));  // 12000 torque values: short enough
  EXPECT_EQ(exact_hyperparameter_rows(o, 3000, 4), 0);
  EXPECT_FALSE(teaches(o, 8000, 2));  // too long to teach: GIP learns from all of it
  EXPECT_EQ(exact_hyperparameter_rows(o, 8000, 2), 8000);
  o.name = "rbf";  // short, but automatic teaching is for gip only: rbf learns from the log
  EXPECT_FALSE(teaches(o, 8000, 1));
  EXPECT_EQ(exact_hyperparameter_rows(o, 8000, 1), 8000);
  o.search.hyperparameter_rows = 2000;
  EXPECT_EQ(exact_hyperparameter_rows(o, 8000, 1), 2000);
  o.search.hyperparameter_rows = 0;
  o.sparse.inducing_points = 300;
  EXPECT_EQ(exact_hyperparameter_rows(o, 8000, 1), 0);
  o.sparse.inducing_points = 0;
  for (const char* other : {"pp", "lip", "nn", "fe"}) {
    o.name = other;
    EXPECT_EQ(exact_hyperparameter_rows(o, 8000, 1), 0) << other;
  }
  o.name = "pp";  // with a mean, pp's NLL is the exact GP's, not the weight-space one
  o.gp.mean = MeanKind::Constant;
  EXPECT_EQ(exact_hyperparameter_rows(o, 8000, 1), 8000);
  EXPECT_EQ(long_exact_fit_warning(kLongExactFitRows - 1), "");
  EXPECT_NE(long_exact_fit_warning(kLongExactFitRows).find("8000 x 8000 matrix"), std::string::npos);
}

TEST(Teacher, DrawsSeededStatesInTheLogsBoxLabelledWithTheTeachersTorques) {
  const Eigen::MatrixXd X = two_link_trajectory(80, 0.15, 1);
  const Eigen::MatrixXd Y = test::with_noise(two_link_torques(X), 0.01, 2);
  TeacherOptions o;
  o.states = 400;
  o.hyperparameter_rows = 0;
  o.seed = 5;
  const TeachingSet set = teach(o, EstimatorOptions{}, X, Y, kTwoLink);
  ASSERT_TRUE(set.teacher_report.ok()) << set.teacher_report.message;
  ASSERT_TRUE(set.teacher);
  EXPECT_EQ(set.teacher->name(), "lip");
  ASSERT_EQ(set.X.rows(), 400);
  ASSERT_EQ(set.X.cols(), 6);
  ASSERT_EQ(set.Y.rows(), 400);
  ASSERT_EQ(set.Y.cols(), 2);

  // Every drawn coordinate inside the log's range, and together they fill it.
  const Eigen::RowVectorXd lo = X.colwise().minCoeff(), hi = X.colwise().maxCoeff();
  for (Eigen::Index c = 0; c < 6; ++c) {
    EXPECT_GE(set.X.col(c).minCoeff(), lo(c)) << "column " << c;
    EXPECT_LE(set.X.col(c).maxCoeff(), hi(c)) << "column " << c;
    EXPECT_GT(set.X.col(c).maxCoeff() - set.X.col(c).minCoeff(), 0.95 * (hi(c) - lo(c))) << "column " << c;
  }
  // Not the log's states: joint 1's and joint 2's positions are drawn independently, so
  // their correlation along the drawn states is near zero whatever it is along the log.
  const Eigen::VectorXd a = set.X.col(0).array() - set.X.col(0).mean(), b = set.X.col(1).array() - set.X.col(1).mean();
  EXPECT_LT(std::abs(a.dot(b)) / (a.norm() * b.norm()), 0.15);

  // The labels are the teacher's torques, without noise; their uncertainty,
  // the student's noise floor, is the teacher's RMS residual on the log.
  EXPECT_TRUE(set.Y == set.teacher->predict(set.X));
  const Eigen::MatrixXd residual = Y - set.teacher->predict(X);
  for (int j = 0; j < 2; ++j) {
    const double rms = std::sqrt(residual.col(j).squaredNorm() / static_cast<double>(X.rows()));
    EXPECT_NEAR(set.label_noise_std(j), rms, 1e-12 * rms) << "joint " << j + 1;
    EXPECT_EQ(set.student_noise_std_floor(j), set.label_noise_std(j)) << "joint " << j + 1;
    EXPECT_GT(rms, 0.003) << "joint " << j + 1 << ": the log's noise is 0.01";
  }

  // The same seed draws the same states and labels; another seed others.
  const TeachingSet again = teach(o, EstimatorOptions{}, X, Y, kTwoLink);
  EXPECT_TRUE(again.X == set.X);
  EXPECT_TRUE(again.Y == set.Y);
  o.seed = 6;
  const TeachingSet other = teach(o, EstimatorOptions{}, X, Y, kTwoLink);
  EXPECT_GT((other.X - set.X).cwiseAbs().maxCoeff(), 0.1);
}

TEST(Teacher, AJointWhoseLoggedTorqueNeverChangesIsLabelledWithThatTorque) {
  // A locked joint: the teacher knows only its one value, and its predictions
  // there differ from it by rounding that the student must not learn as signal.
  const Eigen::MatrixXd X = two_link_trajectory(60, 0.15, 1);
  Eigen::MatrixXd Y = test::with_noise(two_link_torques(X), 0.01, 2);
  Y.col(1).setConstant(0.25);
  TeacherOptions o;
  o.states = 100;
  const TeachingSet set = teach(o, EstimatorOptions{}, X, Y, kTwoLink);
  ASSERT_TRUE(set.teacher_report.ok()) << set.teacher_report.message;
  EXPECT_TRUE((set.Y.col(1).array() == 0.25).all());
  EXPECT_EQ(set.student_noise_std_floor(1), 0.0) << "a constant is known exactly";
  EXPECT_GT(set.student_noise_std_floor(0), 0.003);
  EXPECT_GT(set.Y.col(0).maxCoeff() - set.Y.col(0).minCoeff(), 1.0);
}

TEST(Teacher, AJointWhoseTorqueTheTeacherCallsNoiseIsLabelledWithItsLoggedMean) {
  // Joint 2's logged torque is noise around a constant: the teacher learns
  // nothing of it, and its torques at drawn states would be extrapolation of
  // that nothing. Joint 1 keeps its teacher's torques.
  const Eigen::MatrixXd X = two_link_trajectory(400, 0.15, 1);
  Eigen::MatrixXd Y = test::with_noise(two_link_torques(X), 0.01, 2);
  Y.col(1) = test::with_noise(Eigen::MatrixXd::Constant(X.rows(), 1, 0.25), 0.01, 3);
  TeacherOptions o;
  o.states = 100;
  const TeachingSet set = teach(o, EstimatorOptions{}, X, Y, kTwoLink);
  ASSERT_TRUE(set.teacher_report.ok()) << set.teacher_report.message;
  const double variance = (Y.col(1).array() - Y.col(1).mean()).square().mean();
  EXPECT_GE(set.label_noise_std(1) * set.label_noise_std(1), kTeacherNoiseShareForMeanLabels * variance)
      << "the teacher calls " << set.label_noise_std(1) * set.label_noise_std(1) / variance << " of it noise";
  EXPECT_TRUE((set.Y.col(1).array() == Y.col(1).mean()).all());
  EXPECT_EQ(set.student_noise_std_floor(1), 0.0);
  EXPECT_GT(set.Y.col(0).maxCoeff() - set.Y.col(0).minCoeff(), 1.0);
  // A joint the teacher learned keeps the teacher's torques.
  EXPECT_TRUE(set.Y.col(0) == set.teacher->predict(set.X).col(0));
}

TEST(Teacher, GipTaughtByLipOnAShortMotionPredictsANewMotionLikeLip) {
  // One short motion of the 2R arm, a new motion to predict.
  const Log log = short_two_link_log();
  const Eigen::MatrixXd &X = log.X, &Y = log.Y;
  const Eigen::MatrixXd Xtest = two_link_trajectory(300, 0.1, 13);
  const Eigen::MatrixXd truth = two_link_torques(Xtest);

  EstimatorOptions gip;
  FitResult on_log = fit_estimator(gip, X, Y, kTwoLink);
  EstimatorOptions lip;
  lip.name = "lip";
  FitResult teacher = fit_estimator(lip, X, Y, kTwoLink);
  EstimatorOptions taught;
  taught.teacher = TeacherOptions{};
  taught.teacher->states = 600;
  FitResult student = fit_estimator(taught, X, Y, kTwoLink);
  ASSERT_TRUE(on_log.report.ok() && teacher.report.ok() && student.report.ok()) << student.report.message;
  ASSERT_TRUE(student.teacher_report);
  EXPECT_TRUE(student.teacher_report->ok());
  EXPECT_EQ(student.estimator->name(), "gip");
  EXPECT_EQ(student.label_noise_std.size(), 2);

  const double e_gip = mean_nmse(truth, on_log.estimator->predict(Xtest));
  const double e_lip = mean_nmse(truth, teacher.estimator->predict(Xtest));
  const double e_taught = mean_nmse(truth, student.estimator->predict(Xtest));
  // Measured: GIP on the log 0.12, LIP 8.4e-5, GIP taught by LIP 8.4e-5 (8.9e-5 with
  // its hyperparameters on all 600 states instead of 500).
  EXPECT_LT(e_taught, 3.0 * e_lip) << "GIP on the log " << e_gip << ", LIP " << e_lip;
  EXPECT_LT(30.0 * e_taught, e_gip) << "LIP " << e_lip;

  // On the log it was taught from, the student fits as its teacher does: no warning.
  ASSERT_TRUE(student.teaching_check);
  const TeachingCheck& check = *student.teaching_check;
  const Eigen::VectorXd on_the_log = compute_accuracy(Y, student.estimator->predict(X)).nmse;
  for (int j = 0; j < 2; ++j) {
    EXPECT_NEAR(check.student_nmse(j), on_the_log(j), 1e-12) << "joint " << j + 1;
    const double variance = (Y.col(j).array() - Y.col(j).mean()).square().mean();
    EXPECT_NEAR(check.teacher_nmse(j), std::pow(student.label_noise_std(j), 2) / variance, 1e-12) << "joint " << j + 1;
    EXPECT_LT(check.student_nmse(j) - check.teacher_nmse(j), 0.01) << "joint " << j + 1;
  }
  EXPECT_EQ(check.warning("lip"), "");
  EXPECT_TRUE(check.passed());
  EXPECT_EQ(student.teaching, TeachingOutcome::Taught);

  // TeachingMode::Automatic keeps a taught model that fits the log: the same model.
  EstimatorOptions automatic = taught;
  automatic.teacher->mode = TeachingMode::Automatic;
  const FitResult kept = fit_estimator(automatic, X, Y, kTwoLink);
  ASSERT_TRUE(kept.report.ok()) << kept.report.message;
  EXPECT_EQ(kept.teaching, TeachingOutcome::Taught);
  EXPECT_TRUE(kept.estimator->predict(Xtest).isApprox(student.estimator->predict(Xtest), 1e-12));

  // ... and does not teach a log of more torque values than automatic_max_log_values:
  // the model is the one learned from the log.
  automatic.teacher->automatic_max_log_values = 2 * X.rows() - 1;
  const FitResult long_log = fit_estimator(automatic, X, Y, kTwoLink);
  ASSERT_TRUE(long_log.report.ok()) << long_log.report.message;
  EXPECT_EQ(long_log.teaching, TeachingOutcome::LogTooLong);
  EXPECT_FALSE(long_log.teacher_report);
  EXPECT_TRUE(long_log.estimator->predict(Xtest).isApprox(on_log.estimator->predict(Xtest), 1e-12));
  automatic.teacher->automatic_max_log_values = 2 * X.rows();
  EXPECT_TRUE(automatic.teacher->teaches(X.rows(), 2));
}

TEST(Teacher, AStudentThatMissesTheLogItsTeacherFitsIsWarnedAbout) {
  // Ten drawn states cannot tell the student the 2R arm's torque over a
  // six-dimensional box: it then fits the log far worse than LIP does, the
  // way a real robot's log, whose states fill little of their box, makes it.
  const Log log = short_two_link_log();
  const Eigen::MatrixXd &X = log.X, &Y = log.Y;
  EstimatorOptions taught;
  taught.teacher = TeacherOptions{};
  taught.teacher->states = 10;
  const FitResult student = fit_estimator(taught, X, Y, kTwoLink);
  ASSERT_TRUE(student.report.ok()) << student.report.message;
  ASSERT_TRUE(student.teaching_check);
  const TeachingCheck& check = *student.teaching_check;
  // Measured: teacher 2.9e-4 and 1.3e-4, student 0.057 and 2.56.
  EXPECT_LT(check.teacher_nmse.maxCoeff(), 0.01);
  EXPECT_GT(check.student_nmse(1), check.teacher_nmse(1) + kTaughtNmseGapWarning);
  const std::string warning = check.warning("lip");
  EXPECT_NE(warning.find("taught by lip"), std::string::npos) << warning;
  EXPECT_NE(warning.find("joint 2 ("), std::string::npos) << warning;
  EXPECT_NE(warning.find("without a teacher"), std::string::npos) << warning;
  EXPECT_FALSE(check.passed());
  EXPECT_EQ(student.teaching, TeachingOutcome::Taught);

  // TeachingMode::Automatic does not keep that model: the estimator learns
  // from the log itself, and the result still says what the teaching did.
  taught.teacher->mode = TeachingMode::Automatic;
  const FitResult fallback = fit_estimator(taught, X, Y, kTwoLink);
  ASSERT_TRUE(fallback.report.ok()) << fallback.report.message;
  EXPECT_EQ(fallback.teaching, TeachingOutcome::StudentMissedLog);
  ASSERT_TRUE(fallback.teacher_report && fallback.teaching_check);
  EXPECT_TRUE(fallback.teacher_report->ok());
  EXPECT_EQ(fallback.teaching_check->student_nmse, check.student_nmse);
  const FitResult on_log = fit_estimator(EstimatorOptions{}, X, Y, kTwoLink);
  ASSERT_TRUE(on_log.report.ok()) << on_log.report.message;
  EXPECT_TRUE(fallback.estimator->predict(X).isApprox(on_log.estimator->predict(X), 1e-12));
  EXPECT_LT(compute_accuracy(Y, fallback.estimator->predict(X)).nmse(1), check.teacher_nmse(1) + kTaughtNmseGapWarning);
  EXPECT_NE(describe(fallback.teaching, "lip").find("learned from the log"), std::string::npos);
}

TEST(Teacher, AStudentThatCannotStartLeavesTheAutomaticFitOnTheLog) {
  // An exact GP on this many drawn states needs terabytes: the student's memory
  // check refuses it. Asked for, that is the fit's error; automatic, the estimator
  // learns from the log, as when the teacher cannot start.
  const Log log = short_two_link_log();
  const Eigen::MatrixXd &X = log.X, &Y = log.Y;
  EstimatorOptions o;
  o.teacher = TeacherOptions{};
  o.teacher->states = 400000;
  EXPECT_NE(test::error_of([&] { fit_estimator(o, X, Y, kTwoLink); }).find("needs about"), std::string::npos);
  o.teacher->mode = TeachingMode::Automatic;
  const FitResult fallback = fit_estimator(o, X, Y, kTwoLink);
  ASSERT_TRUE(fallback.report.ok()) << fallback.report.message;
  EXPECT_EQ(fallback.teaching, TeachingOutcome::StudentFailed);
  EXPECT_NE(fallback.student_failure.find("needs about"), std::string::npos) << fallback.student_failure;
  ASSERT_TRUE(fallback.teacher_report && fallback.teacher);  // the teacher's fit stays the user's to keep
  EXPECT_TRUE(fallback.teacher_report->ok());
  EXPECT_FALSE(fallback.teaching_check);
  const FitResult on_log = fit_estimator(EstimatorOptions{}, X, Y, kTwoLink);
  ASSERT_TRUE(on_log.report.ok()) << on_log.report.message;
  EXPECT_TRUE(fallback.estimator->predict(X).isApprox(on_log.estimator->predict(X), 1e-12));
}

TEST(Teacher, TheWarningNamesOnlyTheJointsPastTheGap) {
  TeachingCheck check;
  check.teacher_nmse = Eigen::Vector4d(0.01, 0.2, 0.01, std::nan(""));
  check.student_nmse = Eigen::Vector4d(0.01 + 0.9 * kTaughtNmseGapWarning, 3.0, 0.5, std::nan(""));
  const std::string warning = check.warning("lip");
  EXPECT_EQ(warning.find("joint 1 "), std::string::npos) << warning;
  EXPECT_NE(warning.find("joint 2 (3 against 0.2), 3 (0.5 against 0.01)"), std::string::npos) << warning;
  EXPECT_EQ(warning.find(", 4"), std::string::npos) << warning;
  EXPECT_FALSE(check.passed());
  check.student_nmse(1) = 0.25;
  check.student_nmse(2) = 0.02;
  EXPECT_EQ(check.warning("lip"), "");
  EXPECT_TRUE(check.passed());
  // A joint whose torque is mostly noise: past the gap, but the student adds a
  // seventh of its teacher's residual, not another residual's worth.
  check.teacher_nmse(1) = 0.955;
  check.student_nmse(1) = 1.09;
  EXPECT_EQ(check.warning("lip"), "");
  EXPECT_TRUE(check.passed());
  check.student_nmse(1) = 2.0 * 0.955 + 0.01;
  EXPECT_NE(check.warning("lip").find("joint 2 ("), std::string::npos);
  EXPECT_FALSE(check.passed());
  EXPECT_NE(test::error_of([&] { check_teaching(Eigen::MatrixXd::Ones(3, 2), Eigen::VectorXd::Ones(2),
                                                Eigen::MatrixXd::Ones(3, 1)); }),
            "");
}

// The joints whose teacher is the better model where the check passes: ten
// times the teacher's nMSE and above the floor; not those the warning names.
TEST(Teacher, TheTeacherIsFarAheadOnlyByTheRatioAboveTheFloorAndWhereTheStudentPasses) {
  TeachingCheck check;
  const double floor = kTeacherFarAheadFloor, ratio = kTeacherFarAheadRatio;
  check.teacher_nmse = (Eigen::VectorXd(6) << 3.8e-5, 0.002, 1e-5, 0.01, 0.01, 0.2).finished();
  check.student_nmse =
      (Eigen::VectorXd(6) << 0.044, 0.9 * ratio * 0.002, 0.9 * floor, 0.01 * ratio, std::nan(""), 3.0).finished();
  // Joint 2 is 9x behind, joint 3 below the floor, joint 5's torque constant, joint 6 missed (warned about).
  EXPECT_EQ(check.joints_teacher_far_ahead(), (std::vector<int>{0, 3}));
  EXPECT_NE(check.warning("lip").find("joint 6 ("), std::string::npos);
  check.student_nmse(1) = ratio * 0.002;
  check.student_nmse(2) = 1.1 * floor;
  EXPECT_EQ(check.joints_teacher_far_ahead(), (std::vector<int>{0, 1, 2, 3}));
  check.teacher_nmse(0) = 0.044;
  EXPECT_EQ(check.joints_teacher_far_ahead(), (std::vector<int>{1, 2, 3}));
}

TEST(Teacher, TheStudentLearnsItsHyperparametersOnASubsampleOfTheDrawnStates) {
  const Eigen::MatrixXd X = two_link_trajectory(80, 0.1, 11);
  const Eigen::MatrixXd Y = test::with_noise(two_link_torques(X), 0.01, 12);
  EstimatorOptions o;
  o.search.optimizer.max_iterations = 30;
  o.teacher = TeacherOptions{};
  o.teacher->hyperparameter_rows = 0;
  o.teacher->states = 300;
  o.teacher->student_hyperparameter_rows = 120;
  const auto student_rows = [&] {
    const FitResult r = fit_estimator(o, X, Y, kTwoLink);
    EXPECT_TRUE(r.report.ok()) << r.report.message;
    EXPECT_EQ(r.estimator->gp_model()->num_training_samples(), 300);  // conditioned on every drawn state
    // The student calls at least the teacher's residual noise (its noise floor).
    for (int j = 0; j < 2; ++j) {
      const double scale = r.estimator->gp_model()->output_scale()(j);
      EXPECT_GE(std::sqrt(r.report.joints.at(static_cast<size_t>(j)).noise_variance) * scale,
                (1.0 - 1e-9) * r.label_noise_std(j))
          << "joint " << j + 1;
    }
    return r.report.joints.at(0).hyperparameter_rows;
  };
  EXPECT_EQ(student_rows(), 120);
  o.search.hyperparameter_rows = 150;  // the student's own option wins
  EXPECT_EQ(student_rows(), 150);
  o.search.hyperparameter_rows = 0;
  o.teacher->student_hyperparameter_rows = 0;  // every drawn state
  EXPECT_EQ(student_rows(), 0);
  EXPECT_EQ(TeacherOptions{}.student_search(SearchSettings{}).hyperparameter_rows, 500);
}

TEST(Teacher, AutomaticTeachingIsForTheGipKernelsExactGpAlone) {
  EstimatorOptions o;
  EXPECT_TRUE(automatic_teaching_applies(o));
  const auto refused = [](auto change) {
    EstimatorOptions changed;
    change(changed);
    return !automatic_teaching_applies(changed);
  };
  EXPECT_TRUE(refused([](EstimatorOptions& c) { c.name = "rbf"; }));
  EXPECT_TRUE(refused([](EstimatorOptions& c) { c.name = "gip-envelope+friction"; }));
  EXPECT_TRUE(refused([](EstimatorOptions& c) { c.sparse.inducing_points = 100; }));
  EXPECT_TRUE(refused([](EstimatorOptions& c) { c.gp.warm_start_rows = 100; }));
  EXPECT_TRUE(refused([](EstimatorOptions& c) { c.gp.mean = MeanKind::Linear; }));
  EXPECT_TRUE(refused([](EstimatorOptions& c) { c.robot_prior.robot = std::make_shared<const RobotModel>(load_robot("scara")); }));

  // Elsewhere the automatic teacher steps aside: the same model as without one, and the result says why.
  const Eigen::MatrixXd X = two_link_trajectory(60, 0.1, 11);
  const Eigen::MatrixXd Y = test::with_noise(two_link_torques(X), 0.01, 12);
  o.name = "rbf";
  o.search.optimizer.max_iterations = 20;
  const FitResult own = fit_estimator(o, X, Y, kTwoLink);
  o.teacher = TeacherOptions{};
  o.teacher->mode = TeachingMode::Automatic;
  const FitResult automatic = fit_estimator(o, X, Y, kTwoLink);
  ASSERT_TRUE(own.report.ok() && automatic.report.ok()) << automatic.report.message;
  EXPECT_EQ(own.teaching, TeachingOutcome::NoTeacher);
  EXPECT_EQ(automatic.teaching, TeachingOutcome::NotApplicable);
  EXPECT_FALSE(automatic.teacher_report || automatic.teaching_check || automatic.teacher);
  EXPECT_TRUE(automatic.estimator->predict(X).isApprox(own.estimator->predict(X), 1e-12));
  EXPECT_NE(describe(automatic.teaching, "lip").find("learned from the log"), std::string::npos);
  // TeachingMode::Always teaches whatever the estimator: the user asked for it.
  o.teacher->mode = TeachingMode::Always;
  o.teacher->states = 100;
  const FitResult taught = fit_estimator(o, X, Y, kTwoLink);
  ASSERT_TRUE(taught.report.ok()) << taught.report.message;
  EXPECT_EQ(taught.teaching, TeachingOutcome::Taught);
  EXPECT_EQ(taught.estimator->gp_model()->num_training_samples(), 100);
  ASSERT_TRUE(taught.teacher);  // the fitted teacher comes back with the result
  EXPECT_EQ(taught.teacher->name(), "lip");
}

// Every search setting of the student reaches the teacher; what describes the
// student's own model does not.
TEST(Teacher, TheTeacherSearchesAsTheStudentDoesForItsOwnModel) {
  EstimatorOptions student;
  student.name = "gip-friction";
  student.search.optimizer.max_iterations = 77;
  student.search.optimizer.lbfgs_memory = 13;
  student.search.gradient_tolerance_per_row = 3e-6;
  student.search.restarts = 2;
  student.search.restart_spread = 0.5;
  student.search.seed = 41;
  student.search.initial_noise_fraction = 0.05;
  student.search.min_noise_fraction = 1e-6;
  student.search.jitter.max_relative = 1e-3;
  student.search.threads = 3;
  student.serial_chain = false;
  student.search.start_screening_evaluations = 25;
  student.gp.scaling = OutputScaling::None;
  student.gp.mean = MeanKind::Linear;
  student.gp.prior.enabled = true;
  student.gp.warm_start_rows = 100;
  student.sparse.inducing_points = 50;
  student.sparse.hyperparameter_objective = HyperparameterObjective::Exact;
  student.gp.noise_std_floor = Eigen::VectorXd::Ones(4);
  student.gp.initial_log_params = {Eigen::VectorXd::Zero(3)};
  student.robot_prior.robot = std::make_shared<const RobotModel>(scara_robot());
  student.nll_backend = std::make_shared<InProcessNll>(MeanFunction(MeanKind::Zero, 12), Eigen::MatrixXd());
  TeacherOptions t;
  t.hyperparameter_rows = 123;
  const EstimatorOptions o = teacher_estimator_options(t, student);
  EXPECT_EQ(o.name, t.name);
  EXPECT_EQ(o.search.hyperparameter_rows, 123);
  EXPECT_FALSE(o.gp.keep_factor);
  EXPECT_EQ(o.search.optimizer.max_iterations, 77);
  EXPECT_EQ(o.search.optimizer.lbfgs_memory, 13);
  EXPECT_EQ(o.search.gradient_tolerance_per_row, 3e-6);
  EXPECT_EQ(o.search.restarts, 2);
  EXPECT_EQ(o.search.restart_spread, 0.5);
  EXPECT_EQ(o.search.seed, 41u);
  EXPECT_EQ(o.search.initial_noise_fraction, 0.05);
  EXPECT_EQ(o.search.min_noise_fraction, 1e-6);
  EXPECT_EQ(o.search.jitter.max_relative, 1e-3);
  EXPECT_EQ(o.search.threads, 3);
  EXPECT_FALSE(o.serial_chain);
  EXPECT_EQ(o.search.start_screening_evaluations, 25);
  EXPECT_EQ(o.nn.seed, 41u);
  EXPECT_EQ(o.chain.seed, 41u);
  EXPECT_EQ(o.chain.threads, 3);
  const EstimatorOptions defaults;
  EXPECT_EQ(o.gp.scaling, defaults.gp.scaling);
  EXPECT_EQ(o.gp.mean, defaults.gp.mean);
  EXPECT_EQ(o.gp.prior.enabled, defaults.gp.prior.enabled);
  EXPECT_EQ(o.gp.warm_start_rows, defaults.gp.warm_start_rows);
  EXPECT_EQ(o.sparse.inducing_points, defaults.sparse.inducing_points);
  EXPECT_EQ(o.sparse.hyperparameter_objective, defaults.sparse.hyperparameter_objective);
  EXPECT_EQ(o.gp.noise_std_floor.size(), 0);
  EXPECT_TRUE(o.gp.initial_log_params.empty());
  EXPECT_EQ(o.robot_prior.robot, nullptr);
  EXPECT_EQ(o.nll_backend, nullptr);
}

TEST(Teacher, BadOptionsAreNamedBeforeAnyWork) {
  const Eigen::MatrixXd X = two_link_trajectory(40, 0.1, 1);
  const Eigen::MatrixXd Y = two_link_torques(X);
  EstimatorOptions o;
  o.teacher = TeacherOptions{};
  o.teacher->states = 3;
  EXPECT_NE(test::error_of([&] { fit_estimator(o, X, Y, kTwoLink); }).find("TeacherOptions::states"), std::string::npos);
  o.teacher->states = 100;
  o.teacher->hyperparameter_rows = -1;
  EXPECT_NE(test::error_of([&] { fit_estimator(o, X, Y, kTwoLink); }).find("TeacherOptions::hyperparameter_rows"),
            std::string::npos);
  o.teacher->hyperparameter_rows = 0;
  o.teacher->student_hyperparameter_rows = -1;
  EXPECT_NE(test::error_of([&] { fit_estimator(o, X, Y, kTwoLink); }).find("TeacherOptions::student_hyperparameter_rows"),
            std::string::npos);
  o.teacher->student_hyperparameter_rows = 500;
  o.teacher->automatic_max_log_values = -1;
  EXPECT_NE(test::error_of([&] { fit_estimator(o, X, Y, kTwoLink); }).find("TeacherOptions::automatic_max_log_values"),
            std::string::npos);
  o.teacher->automatic_max_log_values = 14000;
  o.teacher->name = "fe";
  EXPECT_NE(test::error_of([&] { fit_estimator(o, X, Y, kTwoLink); }).find("nominal robot"), std::string::npos);
  o.teacher->name = "lap";
  EXPECT_NE(test::error_of([&] { fit_estimator(o, X, Y, kTwoLink); }).find("lip"), std::string::npos);
  o.teacher->name = "lip";
  EXPECT_NE(test::error_of([&] { teach(*o.teacher, EstimatorOptions{}, X, Y.leftCols(1), kTwoLink); }), "");
}

}  // namespace
}  // namespace gipdyn
