// The estimators of issue 4 behind one interface: fe, pp, sp, the GP kernels and nn.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <map>
#include <mutex>
#include <set>
#include <filesystem>
#include <optional>
#include <thread>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/model_selection.hpp"
#include "gipdyn/estimators/online_update.hpp"
#include "gipdyn/estimators/neural_network.hpp"
#include "gipdyn/estimators/options_record.hpp"
#include "gipdyn/estimators/per_joint_estimator.hpp"
#include "gipdyn/gipdyn.h"
#include "gipdyn/estimators/uncertainty.hpp"
#include "gipdyn/io/mat_dataset.hpp"
#include "gipdyn/estimators/fisherian.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/estimators/presets.hpp"
#include "gipdyn/gp/hyperparameter_prior.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/robot/dynamics.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "test_util.hpp"
#include "gipdyn/io/detail/model_container.hpp"

// Present when the BLAS is OpenBLAS.
extern "C" void openblas_set_num_threads(int) __attribute__((weak));

using namespace gipdyn;
using test::error_of;

namespace {

struct Split {
  SimulationResult train, test;
};

// 300 samples at dt = 0.1 s span the motion the test trajectory covers.
Split scara_split(double noise, int samples = 300) {
  SimulationOptions o;
  o.samples = samples;
  o.dt = 0.1;
  o.noise_std = noise;
  o.seed = 11;
  Split s{simulate(scara_robot(), o), {}};
  o.seed = 12;
  s.test = simulate(scara_robot(), o);
  return s;
}

EstimatorOptions options(const std::string& name) {
  EstimatorOptions o;
  o.name = name;
  o.search.optimizer.max_iterations = 60;
  // The bounds record where a 60-evaluation path ends, and that path depends on
  // the L-BFGS memory: with 40 pairs (the default, better to convergence) some
  // gip variants sit higher on joint 2 after 60 evaluations. Pinned to the 10
  // the bounds were recorded with.
  o.search.optimizer.lbfgs_memory = 10;
  o.gp.keep_factor = false;
  o.nn.epochs = 150;
  o.nn.seed = 3;
  if (estimator_needs_robot(name)) o.robot_prior.robot = std::make_shared<const RobotModel>(scara_robot());
  return o;
}

Eigen::VectorXd test_nmse(const Estimator& e, const Split& s) {
  return compute_accuracy(s.test.tau_true, e.predict(s.test.X)).nmse;
}

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("gipdyn_test_estimators_" + name)).string();
}

}  // namespace

// docs/method.md section 6: without model bias or noise the rigid-body model is exact, so least
// squares and the parametric-prior GP recover KDL's torques.
TEST(Estimators, FeAndPpRecoverNoiseFreeTorquesWithoutModelBias) {
  const Split s = scara_split(0.0);
  for (const std::string name : {"fe", "pp"}) {
    FitResult r = fit_estimator(options(name), s.train.X, s.train.tau, scara_robot().joint_types());
    ASSERT_TRUE(r.report.ok()) << name << ": " << r.report.message;
    const Eigen::VectorXd nmse = test_nmse(*r.estimator, s);
    for (int j = 0; j < 4; ++j) EXPECT_LT(nmse(j), 1e-8) << name << " joint " << j + 1;
  }
}

// The UR10's regressor with friction has 72 columns; on joint 2, 52 are not
// zero and their rank is 37. Without a cap on each parameter's prior variance (ParametricKernel::
// restrict_log_params) the likelihood sent a few of them far up (to 3.5e9), the
// final N x N fit needed a jitter of 1e-4 of its diagonal, and on
// 500 rows of seeds 1-3 joints 1-3 tested at nMSE 0.39-1.15 where least squares
// on the same regressor reaches 1e-6.
TEST(Estimators, PpOnTheUr10WithFrictionMatchesTheExactRegressor) {
  SimulationOptions so;
  so.samples = 500;
  so.friction = true;
  so.noise_std = 0.01;
  so.seed = 1;
  const SimulationResult train = simulate(ur10_robot(), so);
  so.samples = 1000;
  so.seed = 101;
  const SimulationResult test = simulate(ur10_robot(), so);
  EstimatorOptions o;
  o.name = "pp";
  o.gp.keep_factor = false;
  o.robot_prior = {std::make_shared<const RobotModel>(ur10_robot()), true};
  FitResult r = fit_estimator(o, train.X, train.tau, ur10_robot().joint_types());
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  const Eigen::VectorXd nmse = compute_accuracy(test.tau_true, r.estimator->predict(test.X)).nmse;
  for (int j = 0; j < 6; ++j) {
    EXPECT_LT(nmse(j), 1e-4) << "joint " << j + 1;
    EXPECT_EQ(r.report.joints[static_cast<size_t>(j)].jitter, 0.0) << "joint " << j + 1;
  }
}

TEST(Estimators, FeUsesTheBaseParametersOfTheScara) {
  const Split s = scara_split(0.0);
  const FisherianEstimator fe = FisherianEstimator::fit({std::make_shared<const RobotModel>(scara_robot()), false},
                                                        s.train.X, s.train.tau);
  EXPECT_EQ(fe.num_base_parameters(), compute_base_parameters(scara_robot(), false).rank);
  // The base weights reproduce the torques of the true full parameter vector.
  const Eigen::MatrixXd Phi = stacked_regressor(scara_robot(), s.test.X.topRows(20));
  EXPECT_LT((Phi * fe.weights() - Phi * scara_robot().inertial_parameters()).norm(),
            1e-8 * (Phi * scara_robot().inertial_parameters()).norm());
}

class EveryEstimator : public ::testing::TestWithParam<std::string> {};

// Bounds about three times the test nMSE each estimator reaches on this split
// (300 noisy samples at dt 0.1 s, 60 L-BFGS evaluations, 150 epochs), per
// joint. Joint 4 carries a torque of a few hundredths of a N m against 0.01 N m
// of noise: the structured estimators reach 0.23, and the generic learners (RBF,
// NN) do worse than predicting the mean there on so few samples (the paper's
// point about data efficiency); their bounds record that, not a goal.
const std::map<std::string, std::array<double, 4>>& reached_nmse_bounds() {
  static const std::map<std::string, std::array<double, 4>> bounds{
      {"fe", {1e-6, 1e-6, 1e-5, 3e-4}},
      {"pp", {1e-6, 1e-6, 1e-5, 3e-3}},
      {"sp", {1e-6, 1e-6, 1e-5, 1.2e-2}},
      {"gip", {5e-5, 5e-5, 1e-4, 0.7}},
      {"gip-friction", {4e-4, 5e-5, 1e-3, 0.7}},
      {"gip+rbf", {1.5e-4, 5e-5, 2.5e-4, 0.7}},
      {"gip-friction+rbf", {7e-3, 5e-5, 2e-4, 0.7}},
      {"gip+friction", {4e-4, 3e-5, 2.5e-5, 0.7}},
      {"gip+friction+rbf", {6e-3, 3e-5, 1.5e-4, 0.7}},
      {"gip-envelope", {3e-3, 4e-5, 1.5e-4, 0.7}},
      {"gip-envelope+friction", {4e-3, 6e-4, 2e-4, 0.7}},
      {"rbf", {0.3, 0.12, 6e-5, 2.3}},
      {"nn", {0.5, 0.6, 0.12, 4.5}},
  };
  return bounds;
}

TEST_P(EveryEstimator, FitsNoisyDataToTheAccuracyItReaches) {
  const Split s = scara_split(0.01);
  FitResult r = fit_estimator(options(GetParam()), s.train.X, s.train.tau, scara_robot().joint_types());
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  EXPECT_EQ(r.estimator->name(), GetParam());
  const Eigen::VectorXd nmse = test_nmse(*r.estimator, s);
  const auto& bound = reached_nmse_bounds().at(GetParam());
  for (int j = 0; j < 4; ++j) EXPECT_LT(nmse(j), bound[static_cast<size_t>(j)]) << "joint " << j + 1 << ": " << nmse.transpose();
  // The paper's claim in miniature: the structured estimators are far ahead of the generic ones on joints 1-2.
  if (GetParam() != "rbf" && GetParam() != "nn") {
    EXPECT_LT(nmse.head(2).maxCoeff(), 1e-2) << nmse.transpose();
  }
}

TEST_P(EveryEstimator, ModelFileRoundTripGivesIdenticalPredictions) {
  const Split s = scara_split(0.01, 120);
  EstimatorOptions o = options(GetParam());
  o.search.optimizer.max_iterations = 10;
  o.nn.epochs = 5;
  FitResult r = fit_estimator(o, s.train.X, s.train.tau, scara_robot().joint_types());
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  const std::string path = temp_path(GetParam() + ".model");
  save_estimator(*r.estimator, path);
  const std::unique_ptr<Estimator> back = load_estimator(path);
  std::filesystem::remove(path);
  EXPECT_EQ(back->name(), GetParam());
  EXPECT_EQ(back->joints().str(), "RRPR");
  const Eigen::MatrixXd a = r.estimator->predict(s.test.X), b = back->predict(s.test.X);
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0);
}

INSTANTIATE_TEST_SUITE_P(Names, EveryEstimator,
                         ::testing::Values("fe", "pp", "sp", "gip", "gip-friction", "rbf", "gip+rbf",
                                           "gip-friction+rbf", "gip+friction", "gip+friction+rbf", "gip-envelope",
                                           "gip-envelope+friction", "nn"),
                         [](const ::testing::TestParamInfo<std::string>& info) { return test::test_name(info.param); });

// The table is the only place a name is spelled; every reader agrees with it.
TEST(EstimatorTable, EveryNameOnceAndEveryRowConsistent) {
  const std::vector<std::string>& names = estimator_names();
  ASSERT_EQ(names.size(), estimator_table().size());
  int defaults = 0, teachers = 0;
  for (const std::string& name : names) {
    EXPECT_EQ(std::count(names.begin(), names.end(), name), 1) << name;
    const EstimatorSpec& e = estimator_spec(name);
    EXPECT_EQ(e.name, name);
    EXPECT_FALSE(e.help.empty()) << name;
    // A GP row is its kernel's row, and the kernel is built by that name.
    EXPECT_EQ(e.family == EstimatorFamily::Gp, e.kernel != nullptr) << name;
    if (e.kernel) {
      EXPECT_EQ(e.kernel->name, name);
      EXPECT_EQ(e.needs_robot, kernel_needs_robot(name));
      RobotPrior prior;
      prior.robot = std::make_shared<const RobotModel>(scara_robot());
      EXPECT_NE(make_kernel(name, FeatureMap(scara_robot().joint_types()), 1, prior), nullptr) << name;
    }
    defaults += e.default_estimator;
    teachers += e.default_teacher;
    if (e.default_teacher) {
      EXPECT_FALSE(e.needs_robot) << "a default teacher must teach without a robot";
    }
    if (!e.preset.empty()) {
      EXPECT_EQ(preset_options(e.preset).name, name);
    }
  }
  EXPECT_EQ(defaults, 1);
  EXPECT_EQ(teachers, 1);
  EXPECT_EQ(EstimatorOptions{}.name, default_estimator_name());
  EXPECT_EQ(TrainOptions{}.kernel, default_estimator_name());
  EXPECT_EQ(TeacherOptions{}.name, default_teacher_name());
  EXPECT_THROW(estimator_spec("gip-turbo"), Error);
  // Variants are columns, read back by family.
  EXPECT_TRUE(estimator_spec(estimator_name(EstimatorFamily::Lagrangian, &EstimatorSpec::friction, true)).friction);
  EXPECT_FALSE(estimator_spec(estimator_name(EstimatorFamily::Lagrangian, &EstimatorSpec::friction, false)).friction);
  for (const std::string& name : physics_estimator_names()) EXPECT_TRUE(estimator_spec(name).rigid_body_terms);
  // The paper's comparisons on simulated data, as its experiments name them.
  auto as_set = [](std::vector<std::string> v) { return std::set<std::string>(v.begin(), v.end()); };
  EXPECT_EQ(as_set(paper_accuracy_estimators()), (std::set<std::string>{"fe", "pp", "sp", "gip", "rbf", "nn"}));
  EXPECT_EQ(as_set(paper_data_efficiency_estimators()), (std::set<std::string>{"gip", "rbf", "nn", "pp"}));
}

TEST(EstimatorTable, TeacherChoiceIsOneRuleForEveryFrontEnd) {
  TeacherOptions settings;
  settings.states = 321;
  EstimatorOptions plain;  // the default estimator, exact GP, no robot
  const std::optional<TeacherOptions> automatic = choose_teacher(kAutomaticTeacher, plain, settings);
  ASSERT_TRUE(automatic.has_value());
  EXPECT_EQ(automatic->name, default_teacher_name());
  EXPECT_EQ(automatic->mode, TeachingMode::Automatic);
  EXPECT_EQ(automatic->states, 321);
  EstimatorOptions sparse = plain;  // automatic teaching is not for a sparse fit: no teacher at all
  sparse.sparse.inducing_points = 50;
  EXPECT_FALSE(choose_teacher(kAutomaticTeacher, sparse, settings).has_value());
  EstimatorOptions rbf;
  rbf.name = "rbf";
  EXPECT_FALSE(choose_teacher(kAutomaticTeacher, rbf, settings).has_value());
  EXPECT_FALSE(choose_teacher(kNoTeacher, plain, settings).has_value());
  const std::optional<TeacherOptions> named = choose_teacher("chain", rbf, settings);
  ASSERT_TRUE(named.has_value());
  EXPECT_EQ(named->name, "chain");
  EXPECT_EQ(named->mode, TeachingMode::Always);
  EXPECT_THROW(choose_teacher("sometimes", plain, settings), Error);
}

TEST(EstimatorTable, TeachingRecordIsWrittenByTheFitAndKeptByModelFiles) {
  const Split s = scara_split(0.01, 80);
  EstimatorOptions o;
  o.search.optimizer.max_iterations = 8;
  TeacherOptions settings;
  settings.states = 150;
  settings.student_hyperparameter_rows = 100;
  o.teacher = choose_teacher(kAutomaticTeacher, o, settings);
  FitResult r = fit_estimator(o, s.train.X, s.train.tau, scara_robot().joint_types());
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  ASSERT_NE(r.estimator->teaching_record(), nullptr);
  const nlohmann::json& record = *r.estimator->teaching_record();
  ASSERT_TRUE(record.is_object());
  EXPECT_EQ(record.at("estimator"), default_teacher_name());
  EXPECT_EQ(record.at("mode"), "automatic");
  EXPECT_EQ(record.at("outcome"), to_string(r.teaching));
  EXPECT_EQ(record.at("states"), 150);
  const std::string path = temp_path("taught.model");
  save_estimator(*r.estimator, path);
  const std::unique_ptr<Estimator> back = load_estimator(path);
  std::filesystem::remove(path);
  ASSERT_NE(back->teaching_record(), nullptr);
  EXPECT_EQ(*back->teaching_record(), record);
  // Without a teacher asked for, no record.
  o.teacher.reset();
  FitResult plain = fit_estimator(o, s.train.X, s.train.tau, scara_robot().joint_types());
  ASSERT_TRUE(plain.report.ok());
  EXPECT_EQ(plain.estimator->teaching_record(), nullptr);
  EXPECT_FALSE(estimator_container(*plain.estimator).header.contains("teacher"));
}

TEST(Estimators, NeuralNetworkIsReproducibleForASeed) {
  const Split s = scara_split(0.01, 100);
  EstimatorOptions o = options("nn");
  o.nn.epochs = 5;
  const JointTypes j = scara_robot().joint_types();
  // The same on a machine whose BLAS runs one thread as on one that runs several.
  if (openblas_set_num_threads) openblas_set_num_threads(1);
  const FitResult fit = fit_estimator(o, s.train.X, s.train.tau, j);
  // Its epochs are a fixed schedule with no convergence test: the report says so rather than "converged".
  EXPECT_EQ(fit.report.status, FitStatus::Completed);
  EXPECT_NE(fit.report.brief_report().find("fit completed"), std::string::npos) << fit.report.brief_report();
  const Eigen::MatrixXd a = fit.estimator->predict(s.test.X);
  if (openblas_set_num_threads) openblas_set_num_threads(4);
  const Eigen::MatrixXd b = fit_estimator(o, s.train.X, s.train.tau, j).estimator->predict(s.test.X);
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0);
  o.nn.seed = 4;
  const Eigen::MatrixXd c = fit_estimator(o, s.train.X, s.train.tau, j).estimator->predict(s.test.X);
  EXPECT_GT((a - c).cwiseAbs().maxCoeff(), 0.0);
}

// Networks fitted side by side (an experiment's concurrent runs) each get the
// weights of their own seed: libtorch's global generator, shared by all threads,
// made them depend on which fit drew its initial weights first.
TEST(Estimators, NeuralNetworksFittedSideBySideEqualThoseFittedOneByOne) {
  const Split s = scara_split(0.01, 60);
  const JointTypes j = scara_robot().joint_types();
  constexpr int fits = 4;
  auto fit = [&](int k) {
    EstimatorOptions o = options("nn");
    o.nn.epochs = 1;
    o.nn.seed = static_cast<std::uint64_t>(k + 1);
    return fit_estimator(o, s.train.X, s.train.tau, j).estimator->predict(s.test.X);
  };
  std::array<Eigen::MatrixXd, fits> one_by_one, side_by_side;
  for (int k = 0; k < fits; ++k) one_by_one[k] = fit(k);
  for (int round = 0; round < 3; ++round) {
    std::atomic<int> ready{0};
    std::vector<std::thread> threads;
    for (int k = 0; k < fits; ++k)
      threads.emplace_back([&, k] {
        ++ready;
        while (ready.load() < fits) std::this_thread::yield();  // start together: their initialisations overlap
        side_by_side[k] = fit(k);
      });
    for (auto& t : threads) t.join();
    for (int k = 0; k < fits; ++k)
      EXPECT_EQ((side_by_side[k] - one_by_one[k]).cwiseAbs().maxCoeff(), 0.0) << "seed " << k + 1 << ", round " << round;
  }
}

TEST(Estimators, NeuralNetworkUsesThePapersLayerWidths) {
  NeuralNetworkOptions o;
  EXPECT_EQ(o.hidden_for(4), (std::vector<int>{400, 400}));
  EXPECT_EQ(o.hidden_for(6), (std::vector<int>{600, 600}));
}

// Early stopping keeps the weights of the epoch with the lowest loss on the held-out stretches, stops `patience`
// epochs after it, and says so; the stored weights give that loss again, computed here from their predictions.
TEST(Estimators, NeuralNetworkKeepsTheEpochWithTheLowestHeldOutLoss) {
  const Split s = scara_split(0.01, 200);
  const JointTypes j = scara_robot().joint_types();
  NeuralNetworkOptions o;
  o.hidden = {16, 16};
  o.epochs = 400;
  o.learning_rate = 1e-2;
  o.patience = 8;
  o.seed = 2;
  // Three of 20 stretches of 10 rows, spread over the log: rows 30-39, 100-109 and 160-169.
  const std::vector<bool> held_out = o.held_out_rows(s.train.X.rows());
  std::vector<Eigen::Index> held_out_rows;
  for (Eigen::Index r = 0; r < s.train.X.rows(); ++r)
    if (held_out[static_cast<size_t>(r)]) held_out_rows.push_back(r);
  ASSERT_EQ(held_out_rows.size(), 30u);
  EXPECT_EQ(held_out_rows.front(), 30);
  EXPECT_EQ(held_out_rows[10], 100);
  EXPECT_EQ(held_out_rows.back(), 169);
  const NeuralNetwork net = NeuralNetwork::train(s.train.X, s.train.tau, j, o);
  ASSERT_LT(net.epochs_run(), o.epochs) << "the held-out loss should stop falling within the epochs on 200 rows";
  EXPECT_EQ(net.epochs_run(), net.kept_epoch() + o.patience);
  EXPECT_EQ(net.held_out_row_count(), 30);
  // The held-out loss: mean square of the held-out rows' residuals in units of each torque column's spread
  // over every row (the network's standardisation).
  const Eigen::MatrixXd& Y = s.train.tau;
  const Eigen::RowVectorXd mean = Y.colwise().mean();
  const Eigen::RowVectorXd spread = ((Y.rowwise() - mean).array().square().colwise().mean()).sqrt().matrix();
  const Eigen::MatrixXd residual =
      (net.predict(s.train.X(held_out_rows, Eigen::all)) - Y(held_out_rows, Eigen::all)).array().rowwise() /
      spread.array();
  EXPECT_NEAR(residual.array().square().mean(), net.validation_loss(), 1e-9 * net.validation_loss());

  EstimatorOptions fit_options = options("nn");
  fit_options.nn = o;
  const FitResult fit = fit_estimator(fit_options, s.train.X, s.train.tau, j);
  EXPECT_EQ(fit.report.status, FitStatus::Converged);
  EXPECT_NE(fit.report.message.find("kept epoch " + std::to_string(net.kept_epoch()) + " of " +
                                    std::to_string(net.epochs_run())),
            std::string::npos)
      << fit.report.message;
  EXPECT_NE(fit.report.message.find("on the 30 rows held out"), std::string::npos) << fit.report.message;
  EXPECT_EQ(fit.estimator->summary().at("kept_epoch").get<int>(), net.kept_epoch());
  EXPECT_EQ(fit.estimator->summary().at("held_out_rows").get<long>(), 30);
  // Stopped by the epoch limit while the held-out loss still fell: not converged, and the fix named.
  fit_options.nn.epochs = 3;
  const FitResult capped = fit_estimator(fit_options, s.train.X, s.train.tau, j);
  EXPECT_EQ(capped.report.status, FitStatus::NotConverged);
  EXPECT_NE(capped.report.message.find("more epochs"), std::string::npos) << capped.report.message;
  // Without a held-out block every row trains for all the epochs.
  fit_options.nn.validation_fraction = 0.0;
  const FitResult every_row = fit_estimator(fit_options, s.train.X, s.train.tau, j);
  EXPECT_EQ(every_row.report.status, FitStatus::Completed);
  EXPECT_EQ(every_row.estimator->summary().at("epochs_run").get<int>(), 3);
  EXPECT_FALSE(every_row.estimator->summary().contains("validation_loss"));
  EXPECT_FALSE(every_row.estimator->summary().contains("held_out_rows"));
  // The kept epoch and its loss survive a save.
  const std::string path = temp_path("early_stopping.gipdyn");
  save_estimator(*fit.estimator, path);
  const std::unique_ptr<Estimator> back = load_estimator(path);
  std::filesystem::remove(path);
  EXPECT_EQ(back->summary(), fit.estimator->summary());
  // Bad settings are one-line errors naming the field.
  o.validation_fraction = 1.0;
  EXPECT_NE(error_of([&] { o.validate(); }).find("NeuralNetworkOptions::validation_fraction"), std::string::npos);
  o.validation_fraction = 0.1;
  o.patience = 0;
  EXPECT_NE(error_of([&] { o.validate(); }).find("NeuralNetworkOptions::patience"), std::string::npos);
}

TEST(Estimators, BadOptionsAndMissingRobotAreOneLineErrors) {
  const Split s = scara_split(0.01, 50);
  const JointTypes j = scara_robot().joint_types();
  EstimatorOptions o = options("fe");
  o.robot_prior = {};
  EXPECT_NE(error_of([&] { fit_estimator(o, s.train.X, s.train.tau, j); }).find("needs the nominal robot (EstimatorOptions::robot_prior)"),
            std::string::npos);
  o = options("pp");
  o.robot_prior.robot = std::make_shared<const RobotModel>(ur10_robot());
  EXPECT_NE(error_of([&] { fit_estimator(o, s.train.X, s.train.tau, j); }).find("has joints RRRRRR"),
            std::string::npos);
  EXPECT_NE(error_of([&] { require_known_estimator("svm"); }).find("choose one of"), std::string::npos);
  o = options("nn");
  o.nn.learning_rate = -1;
  EXPECT_NE(error_of([&] { fit_estimator(o, s.train.X, s.train.tau, j); }).find("NeuralNetworkOptions::learning_rate"), std::string::npos);
}

TEST(Estimators, LoadEstimatorRejectsTruncatedFiles) {
  const Split s = scara_split(0.0, 60);
  FitResult r = fit_estimator(options("fe"), s.train.X, s.train.tau, scara_robot().joint_types());
  ASSERT_TRUE(r.report.ok());
  const std::string path = temp_path("truncated.model");
  save_estimator(*r.estimator, path);
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 20);
  EXPECT_NE(error_of([&] { load_estimator(path); }).find("truncated"), std::string::npos);
  std::filesystem::remove(path);
}

// The .mat original and the CSV of the shared UR10 log hold the same numbers.
TEST(MatDataset, ReadsTheSharedUr10MatFileLikeItsCsv) {
  const std::string dir = GIPDYN_SHARED_DATA "/ur10-pick-and-place/";
  if (!std::filesystem::exists(dir + "URpickNplace.mat")) GTEST_SKIP() << "shared data not present";
  const JointTypes j = JointTypes::parse("RRRRRR");
  const Dataset mat = read_mat_dataset(dir + "URpickNplace.mat", "urPicknPlace", j, true);
  const Dataset csv = read_dataset(dir + "urPicknPlace.csv", j, true);
  ASSERT_EQ(mat.rows(), 12349);
  ASSERT_EQ(csv.rows(), mat.rows());
  // The CSV was written with 10 significant digits.
  EXPECT_LT((mat.X - csv.X).cwiseAbs().maxCoeff(), 1e-8 * mat.X.cwiseAbs().maxCoeff());
  EXPECT_LT((mat.tau - csv.tau).cwiseAbs().maxCoeff(), 1e-8 * mat.tau.cwiseAbs().maxCoeff());
  EXPECT_NE(error_of([&] { read_mat_dataset(dir + "URpickNplace.mat", "nope", j, true); }).find("urPicknPlace"),
            std::string::npos);
  EXPECT_NE(error_of([&] { read_mat_dataset(dir + "URpickNplace.mat", "urPicknPlace", JointTypes::parse("RRRRRRR"),
                                            true); })
                .find("need 28"),
            std::string::npos);
}

// ------------------------------------------------------------- MAP priors

TEST(HyperparameterPrior, PenaltyGradientMatchesFiniteDifferences) {
  const Eigen::VectorXd mu = test::random_vector(7, -2, 2, 31), theta = test::random_vector(7, -4, 4, 32);
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(7);
  const double f = prior_penalty(theta, mu, 1.5, &grad);
  EXPECT_NEAR(f, (theta - mu).squaredNorm() / (2 * 1.5 * 1.5), 1e-12);
  const Eigen::VectorXd fd =
      test::finite_difference([&](const Eigen::VectorXd& t) { return prior_penalty(t, mu, 1.5, nullptr); }, theta, 1e-5);
  EXPECT_LT((grad - fd).norm(), 1e-7 * fd.norm());
}

// With a handful of samples, maximum likelihood moves hyperparameters far from
// their start; the log-normal prior holds them closer, and narrower priors closer still.
TEST(HyperparameterPrior, MapTrainingKeepsHyperparametersNearTheirStart) {
  const Split s = scara_split(0.01, 12);
  const JointTypes j = scara_robot().joint_types();
  auto fitted_params = [&](bool enabled, double width, int max_iter) {
    TrainOptions o;
    o.search.optimizer.max_iterations = max_iter;
    o.gp.prior.enabled = enabled;
    o.gp.prior.width = width;
    o.search.threads = 1;
    TrainResult r = train_model(s.train.X, s.train.tau, j, o);
    EXPECT_TRUE(r.report.ok()) << r.report.message;
    return r.model.joint_gp(0).kernel().log_params();
  };
  const Eigen::VectorXd start = fitted_params(false, 1.0, 1);  // one evaluation: the data-driven start
  const double ml = (fitted_params(false, 1.0, 200) - start).norm();
  const double wide = (fitted_params(true, 3.0, 200) - start).norm();
  const double narrow = (fitted_params(true, 0.3, 200) - start).norm();
  EXPECT_LT(wide, ml);
  EXPECT_LT(narrow, wide);
  EXPECT_NE(error_of([] {
              HyperparameterPrior p;
              p.width = 0;
              p.validate();
            }).find("HyperparameterPrior::width"),
            std::string::npos);
}

// The choice by evidence (model_selection.hpp) against the same fits made by hand.
namespace {

Eigen::MatrixXd first_rows(const Eigen::MatrixXd& M, Eigen::Index rows) { return M.topRows(rows); }

Eigen::VectorXd held_out_nmse(const Estimator& e, const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, Eigen::Index fit) {
  return compute_accuracy(Y.bottomRows(Y.rows() - fit), e.predict(X.bottomRows(X.rows() - fit))).nmse;
}

// A teacher that teaches at few states, for fits of seconds.
TeacherOptions quick_teaching() {
  TeacherOptions teaching;
  teaching.states = 300;
  teaching.student_hyperparameter_rows = 150;
  return teaching;
}

// A choice among candidates on a SCARA log, with quick teaching.
struct SelectionCase {
  EstimatorOptions base = options("gip");
  SelectionOptions so;
  TeacherOptions teaching = quick_teaching();
  explicit SelectionCase(std::vector<std::string> candidates) { so.candidates = std::move(candidates); }
  SelectionResult run(const SimulationResult& log) const {
    return fit_selected_estimator(base, so, log.X, log.tau, scara_robot().joint_types(), teaching);
  }
};

}  // namespace

TEST(ModelSelection, ScoresEachCandidateOnTheHeldOutBlockAsAHandMadeFitDoes) {
  const SimulationResult log = scara_split(0.01, 200).train;
  const SelectionCase choice({"rbf", "gip"});
  const SelectionResult r = choice.run(log);
  const Selection& s = r.selection;
  ASSERT_EQ(s.candidates.size(), 2u);
  EXPECT_EQ(s.fit_rows, 150);
  EXPECT_EQ(s.held_out_rows, 50);
  for (const CandidateScore& c : s.candidates) {
    ASSERT_TRUE(c.ok) << c.name << ": " << c.failure;
    const FitResult by_hand = fit_estimator(candidate_options(c.name, choice.base, choice.teaching), first_rows(log.X, 150),
                                            first_rows(log.tau, 150), scara_robot().joint_types());
    ASSERT_TRUE(by_hand.report.ok());
    EXPECT_TRUE(c.nmse.isApprox(held_out_nmse(*by_hand.estimator, log.X, log.tau, 150), 1e-9)) << c.name;
    EXPECT_DOUBLE_EQ(c.mean_nmse, c.nmse.mean());
  }
  // On a rigid arm GIP beats the RBF GP on a motion it did not see, by far more than the tie tolerance.
  EXPECT_LT(s.candidates[1].mean_nmse, 0.5 * s.candidates[0].mean_nmse);
  EXPECT_EQ(s.best, "gip");
  EXPECT_EQ(s.chosen, "gip");
  // The chosen candidate refitted on every row, the choice recorded in the model and its file.
  ASSERT_TRUE(r.fit.report.ok());
  EXPECT_EQ(r.refit_rows, 200);
  EXPECT_EQ(r.options.name, "gip");
  EXPECT_EQ(r.fit.estimator->name(), "gip");
  ASSERT_NE(r.fit.estimator->selection_record(), nullptr);
  EXPECT_EQ(*r.fit.estimator->selection_record(), s.record());
  EXPECT_EQ(s.record()["chosen"], "gip");
  const std::string path = temp_path("selected.gipdyn");
  save_estimator(*r.fit.estimator, path);
  const auto loaded = load_estimator(path);
  ASSERT_NE(loaded->selection_record(), nullptr);
  EXPECT_EQ((*loaded->selection_record())["candidates"][0]["name"], "rbf");
  EXPECT_NE(s.brief_report().find("chose gip: the lowest mean nMSE"), std::string::npos) << s.brief_report();
}

TEST(ModelSelection, CandidatesThatScoreAlikeGoToTheFirstInTheOrderOfPreference) {
  const SimulationResult log = scara_split(0.01, 120).train;
  EstimatorOptions base = options("gip");
  SelectionOptions so;
  so.candidates = {"rbf", "gip"};
  so.tie_tolerance = 1e6;  // everything scores alike
  const SelectionResult r = fit_selected_estimator(base, so, log.X, log.tau, scara_robot().joint_types());
  EXPECT_EQ(r.selection.best, "gip");
  EXPECT_EQ(r.selection.chosen, "rbf");
  EXPECT_EQ(r.fit.estimator->name(), "rbf");
  EXPECT_NE(r.selection.brief_report().find("chose rbf: within"), std::string::npos);
}

TEST(ModelSelection, GipsTeacherIsScoredAsTheLipCandidateAndMatchesItsOwnFit) {
  const SimulationResult log = scara_split(0.01, 160).train;
  EstimatorOptions base = options("gip");
  SelectionOptions so;
  so.candidates = {"gip", "lip"};
  TeacherOptions teaching = quick_teaching();
  teaching.hyperparameter_rows = 80;
  std::vector<std::string> notes;
  std::mutex mu;
  const ProgressCallback progress = [&](const ProgressEvent& e) {
    std::lock_guard<std::mutex> lock(mu);
    if (e.iteration == 0 && !e.finished) notes.push_back(e.estimator + ": " + e.message);
  };
  const SelectionResult r =
      fit_selected_estimator(base, so, log.X, log.tau, scara_robot().joint_types(), teaching, progress);
  const CandidateScore& lip = r.selection.candidates[1];
  ASSERT_TRUE(lip.ok) << lip.failure;
  // Not fitted a second time: scored as gip's teacher.
  EXPECT_NE(std::find(notes.begin(), notes.end(), "lip: scored as gip's teacher, fitted on the same rows"), notes.end());
  EXPECT_EQ(std::count_if(notes.begin(), notes.end(), [](const std::string& n) { return n.rfind("lip: candidate", 0) == 0; }), 0);
  // The lip candidate fitted on its own, with its candidate options, predicts as the teacher did.
  const FitResult own = fit_estimator(candidate_options("lip", base, teaching), first_rows(log.X, 120),
                                      first_rows(log.tau, 120), scara_robot().joint_types());
  ASSERT_TRUE(own.report.ok());
  EXPECT_TRUE(lip.nmse.isApprox(held_out_nmse(*own.estimator, log.X, log.tau, 120), 1e-9))
      << lip.nmse.transpose() << " vs " << held_out_nmse(*own.estimator, log.X, log.tau, 120).transpose();
}

// A log whose joints call for different models: the SCARA's rigid-body torques on joints 1-3, and on
// joint 4 a torque no low-degree polynomial of the joint angles holds, sin(6 q1), which an RBF GP learns.
SimulationResult log_with_a_non_rigid_joint(int samples) {
  SimulationResult log = scara_split(0.01, samples).train;
  log.tau.col(3) = (6.0 * log.X.col(0).array()).sin().matrix() + 0.01 * log.tau.col(3).normalized();
  return log;
}

TEST(ModelSelection, JointsThatCallForDifferentModelsGetEachItsOwn) {
  const SimulationResult log = log_with_a_non_rigid_joint(160);
  const SelectionCase choice({"gip", "rbf"});
  const SelectionResult r = choice.run(log);
  const Selection& s = r.selection;
  ASSERT_TRUE(s.candidates.size() == 2 && s.candidates[0].ok && s.candidates[1].ok);
  // A joint keeps the choice by mean nMSE unless the other candidate's held-out nMSE on it is below the mean
  // choice's by more than the per-joint factor.
  const CandidateScore& overall = s.chosen == "gip" ? s.candidates[0] : s.candidates[1];
  const CandidateScore& other = s.chosen == "gip" ? s.candidates[1] : s.candidates[0];
  for (Eigen::Index j = 0; j < 4; ++j) {
    const bool other_clearly_better = overall.nmse(j) > other.nmse(j) * choice.so.per_joint_factor;
    EXPECT_EQ(s.chosen_per_joint[static_cast<size_t>(j)], other_clearly_better ? other.name : overall.name)
        << "joint " << j + 1;
  }
  ASSERT_EQ(s.chosen_per_joint[0], "gip");
  ASSERT_EQ(s.chosen_per_joint[3], "rbf") << s.brief_report();
  ASSERT_TRUE(s.per_joint());
  EXPECT_NE(s.brief_report().find("chose per joint"), std::string::npos) << s.brief_report();
  EXPECT_EQ(s.record()["chosen_per_joint"][3], "rbf");
  // The model: each chosen candidate refitted on every row, each joint answered by its own.
  ASSERT_TRUE(r.fit.report.ok()) << r.fit.report.message;
  ASSERT_EQ(r.fit.estimator->name(), PerJointEstimator::kName);
  const auto& per_joint = dynamic_cast<const PerJointEstimator&>(*r.fit.estimator);
  EXPECT_EQ(per_joint.joint_model_names(), s.chosen_per_joint);
  // Each model is its candidate refitted on every row, as a fit by hand gives it.
  const auto rbf = std::find_if(per_joint.models().begin(), per_joint.models().end(),
                                [](const auto& m) { return m->name() == "rbf"; });
  ASSERT_NE(rbf, per_joint.models().end());
  const FitResult by_hand =
      fit_estimator(candidate_options("rbf", choice.base, choice.teaching), log.X, log.tau, scara_robot().joint_types());
  ASSERT_TRUE(by_hand.report.ok());
  EXPECT_TRUE((*rbf)->predict(log.X).isApprox(by_hand.estimator->predict(log.X), 1e-9));
  EXPECT_EQ(r.fit.report.joints.size(), 4u);
  // Physics only where every joint's model has it, and the refusal names the joint that has not.
  EXPECT_NE(error_of([&] { gravity(*r.fit.estimator, log.X.leftCols(4)); }).find("4 (rbf)"),
            std::string::npos);
  // On the joint the RBF took, the composite predicts later rows of the motion far better than the GIP model in it.
  const SimulationResult later = log_with_a_non_rigid_joint(200);
  const Eigen::MatrixXd X_new = later.X.bottomRows(40), Y_new = later.tau.bottomRows(40);
  const auto gip = std::find_if(per_joint.models().begin(), per_joint.models().end(),
                                [](const auto& m) { return m->name() == "gip"; });
  ASSERT_NE(gip, per_joint.models().end());
  EXPECT_LT(compute_accuracy(Y_new, r.fit.estimator->predict(X_new)).nmse(3),
            0.5 * compute_accuracy(Y_new, (*gip)->predict(X_new)).nmse(3));
}

TEST(PerJointEstimator, AnswersEachJointFromItsModelInBatchQueriesPhysicsAndFiles) {
  const Split s = scara_split(0.01, 120);
  const JointTypes joints = scara_robot().joint_types();
  FitResult a = fit_estimator(options("gip"), s.train.X, s.train.tau, joints);
  FitResult b = fit_estimator(options("gip-friction"), s.train.X, s.train.tau, joints);
  ASSERT_TRUE(a.report.ok() && b.report.ok());
  const std::shared_ptr<const Estimator> ea = std::move(a.estimator), eb = std::move(b.estimator);
  PerJointEstimator composite({ea, eb}, {0, 1, 1, 0});
  composite.set_selection_record({{"chosen_per_joint", {"gip", "gip-friction", "gip-friction", "gip"}}});
  const Eigen::MatrixXd X = s.test.X.topRows(20);
  const Eigen::MatrixXd pa = ea->predict(X), pb = eb->predict(X), p = composite.predict(X);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(p.col(i), (i == 1 || i == 2 ? pb : pa).col(i)) << "joint " << i + 1;
  EXPECT_EQ(composite.joint_model_names(), (std::vector<std::string>{"gip", "gip-friction", "gip-friction", "gip"}));

  // One query at a time: the same torques, and each joint's row of gravity, M and the bias from its model.
  const auto ws = composite.make_query_workspace();
  const auto wa = ea->make_query_workspace(), wb = eb->make_query_workspace();
  EXPECT_EQ(ws->allocation_free(), wa->allocation_free() && wb->allocation_free());
  Eigen::VectorXd tau(4), g(4), bias(4), ga(4), gb(4), biasa(4), biasb(4);
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> M, Ma, Mb;
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    const Eigen::RowVectorXd x = X.row(r);
    ws->predict(x.data(), tau.data());
    EXPECT_TRUE(tau.isApprox(p.row(r).transpose(), 1e-10)) << "row " << r;
    ws->rigid_body_terms(x.data(), x.data() + 4, g.data(), M.data(), bias.data());
    wa->rigid_body_terms(x.data(), x.data() + 4, ga.data(), Ma.data(), biasa.data());
    wb->rigid_body_terms(x.data(), x.data() + 4, gb.data(), Mb.data(), biasb.data());
    for (int i = 0; i < 4; ++i) {
      const bool from_b = i == 1 || i == 2;
      EXPECT_EQ(g(i), from_b ? gb(i) : ga(i));
      EXPECT_EQ(bias(i), from_b ? biasb(i) : biasa(i));
      EXPECT_EQ(M.row(i), from_b ? Mb.row(i) : Ma.row(i));
    }
  }
  // The batch physics of physics.hpp, from the same rows.
  ASSERT_TRUE(composite.gives_rigid_body_terms());
  const Eigen::MatrixXd Q = X.leftCols(4);
  const Eigen::MatrixXd grav = gravity(composite, Q), grav_a = gravity(*ea, Q), grav_b = gravity(*eb, Q);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(grav.col(i).isApprox((i == 1 || i == 2 ? grav_b : grav_a).col(i), 1e-12));
  // No predictive variance: the models' noises do not make one calibrated model.
  EXPECT_FALSE(composite.gives_uncertainty());
  EXPECT_NE(error_of([&] { TorqueUncertainty u(composite); }).find("'chosen-per-joint' model gives no predictive standard deviation"),
            std::string::npos);

  // A model file holds every model and the assignment, and gives back the same predictions and records.
  const std::string path = temp_path("per_joint.gipdyn");
  save_estimator(composite, path);
  const auto loaded = load_estimator(path);
  ASSERT_EQ(loaded->name(), PerJointEstimator::kName);
  EXPECT_EQ(loaded->predict(X), p);
  ASSERT_NE(loaded->selection_record(), nullptr);
  EXPECT_EQ(*loaded->selection_record(), *composite.selection_record());
  EXPECT_EQ(dynamic_cast<const PerJointEstimator&>(*loaded).joint_model(), (std::vector<int>{0, 1, 1, 0}));
  // The C API serves it as any model: the same torques and gravity, one query at a time.
  gipdyn_model* c_model = nullptr;
  ASSERT_EQ(gipdyn_model_load(path.c_str(), &c_model), GIPDYN_OK) << gipdyn_last_error();
  EXPECT_EQ(gipdyn_model_has_physics(c_model), 1);
  gipdyn_workspace* c_ws = nullptr;
  ASSERT_EQ(gipdyn_workspace_create(c_model, &c_ws), GIPDYN_OK);
  const Eigen::RowVectorXd x0 = X.row(0);
  Eigen::VectorXd c_tau(4), c_g(4);
  ASSERT_EQ(gipdyn_predict(c_ws, x0.data(), x0.data() + 4, x0.data() + 8, 4, c_tau.data()), GIPDYN_OK);
  EXPECT_TRUE(c_tau.isApprox(p.row(0).transpose(), 1e-10));
  ASSERT_EQ(gipdyn_gravity(c_ws, x0.data(), 4, c_g.data()), GIPDYN_OK);
  EXPECT_TRUE(c_g.isApprox(grav.row(0).transpose(), 1e-10));
  gipdyn_workspace_free(c_ws);
  gipdyn_model_free(c_model);
  std::filesystem::remove(path);

  // What cannot make one: every message names the problem.
  EXPECT_NE(error_of([&] { PerJointEstimator({ea}, {0, 0, 1, 0}); }).find("index 1 outside"), std::string::npos);
  EXPECT_NE(error_of([&] { PerJointEstimator({ea, eb}, {0, 0, 0, 0}); }).find("model 1 answers no joint"),
            std::string::npos);
  EXPECT_NE(error_of([&] { PerJointEstimator({ea}, {0, 0}); }).find("2 joint models for 4 joints"), std::string::npos);
  FitResult other = fit_estimator(options("gip"), s.train.X, s.train.tau, JointTypes::parse("RRRR"));
  ASSERT_TRUE(other.report.ok());
  const std::shared_ptr<const Estimator> eo = std::move(other.estimator);
  EXPECT_NE(error_of([&] { PerJointEstimator({ea, eo}, {0, 1, 0, 0}); }).find("different joints (RRPR and RRRR)"),
            std::string::npos);
}

TEST(ModelSelection, ALogTooShortOrBadOptionsAreRefusedBeforeAnyWork) {
  const SimulationResult log = scara_split(0.01, 30).train;
  const JointTypes joints = scara_robot().joint_types();
  EXPECT_NE(error_of([&] { fit_selected_estimator(options("gip"), {}, log.X, log.tau, joints); })
                .find("a log of 30 rows is too short to choose an estimator by evidence"),
            std::string::npos);
  SelectionOptions bad;
  bad.held_out_fraction = 1.0;
  EXPECT_NE(error_of([&] { fit_selected_estimator(options("gip"), bad, log.X, log.tau, joints); })
                .find("SelectionOptions::held_out_fraction must be in (0, 1)"),
            std::string::npos);
  bad = SelectionOptions{};
  bad.per_joint_factor = 0.5;
  EXPECT_NE(error_of([&] { fit_selected_estimator(options("gip"), bad, log.X, log.tau, joints); })
                .find("SelectionOptions::per_joint_factor must be >= 1"),
            std::string::npos);
  SelectionOptions unknown;
  unknown.candidates = {"gip", "magic"};
  EXPECT_NE(error_of([&] { fit_selected_estimator(options("gip"), unknown, log.X, log.tau, joints); }).find("magic"),
            std::string::npos);
  // The table's candidates in their order of preference: the default first, the RBF baseline last.
  const std::vector<std::string> candidates = selection_candidates();
  ASSERT_GE(candidates.size(), 3u);
  EXPECT_EQ(candidates.front(), default_estimator_name());
  EXPECT_EQ(candidates.back(), "rbf");
}

// The update rule every front end follows (online_update.hpp).
TEST(OnlineUpdateRule, ReLearnsWhereTheCheckFailsRefusesOnRequestAndRefusesATaughtModel) {
  const Split s = scara_split(0.01, 120);
  // Every other row of the motion, then the rows between them: the same motion.
  const Eigen::MatrixXd X_even = s.train.X(Eigen::seq(0, Eigen::last, 2), Eigen::all);
  const Eigen::MatrixXd Y_even = s.train.tau(Eigen::seq(0, Eigen::last, 2), Eigen::all);
  const Eigen::MatrixXd X_odd = s.train.X(Eigen::seq(1, Eigen::last, 2), Eigen::all);
  const Eigen::MatrixXd Y_odd = s.train.tau(Eigen::seq(1, Eigen::last, 2), Eigen::all);
  EstimatorOptions o = options("gip");
  const FitResult fit = fit_estimator(o, X_even, Y_even, scara_robot().joint_types());
  ASSERT_TRUE(fit.report.ok());
  // The rows between: the check passes and the hyperparameters stay.
  UpdateOptions keep;
  keep.refit = UpdateRefit::Never;
  const UpdateResult same = update_estimator(*fit.estimator, X_odd, Y_odd, keep);
  ASSERT_TRUE(same.check.has_value());
  EXPECT_TRUE(same.check->passed()) << same.check->brief_report();
  EXPECT_FALSE(same.refitted);
  EXPECT_EQ(same.estimator->gp_model()->num_training_samples(), 120);
  // A heavier arm's rows: refused with UpdateRefit::Never, re-learned from the data-driven start by default.
  Eigen::MatrixXd heavier = Y_odd;
  heavier.col(0) *= 3.0;
  EXPECT_NE(error_of([&] { update_estimator(*fit.estimator, X_odd, heavier, keep); })
                .find("UpdateOptions::refit where-misfit"),
            std::string::npos);
  UpdateOptions relearn;
  relearn.search.optimizer.max_iterations = 30;
  const UpdateResult misfit = update_estimator(*fit.estimator, X_odd, heavier, relearn);
  EXPECT_TRUE(misfit.refitted);
  EXPECT_EQ(misfit.refit_start, RefitStart::DataDriven);
  EXPECT_EQ(misfit.check->misfit_joints().front(), 0);
  UpdateOptions always = relearn;
  always.refit = UpdateRefit::Always;
  const UpdateResult periodic = update_estimator(*fit.estimator, X_odd, Y_odd, always);
  EXPECT_TRUE(periodic.refitted);
  EXPECT_EQ(periodic.refit_start, RefitStart::CurrentHyperparameters);
  // A taught model: refused, naming its teacher and the fix.
  EstimatorOptions taught_options = o;
  TeacherOptions teaching = quick_teaching();
  teaching.mode = TeachingMode::Always;
  taught_options.teacher = teaching;
  const FitResult taught = fit_estimator(taught_options, s.train.X, s.train.tau, scara_robot().joint_types());
  ASSERT_EQ(taught.teaching, TeachingOutcome::Taught);
  EXPECT_NE(error_of([&] { update_estimator(*taught.estimator, s.test.X.topRows(5), s.test.tau.topRows(5), {}); })
                .find("this model was taught by lip"),
            std::string::npos);
  EXPECT_EQ(parse_update_refit(to_string(UpdateRefit::Never)), UpdateRefit::Never);
  EXPECT_NE(error_of([] { parse_update_refit("sometimes"); }).find("UpdateOptions::refit must be"), std::string::npos);
}

// The model file's options block gives back the options a fit had (every field a front end sets), and a
// record that lacks a field, or holds one of the wrong type, is read or refused by name.
TEST(OptionsRecord, GivesBackTheOptionsAFitHad) {
  EstimatorOptions o;
  o.name = "rbf";
  o.search.optimizer.kind = OptimizerKind::Adam;
  o.search.optimizer.max_iterations = 17;
  o.search.optimizer.lbfgs_memory = 9;
  o.search.optimizer.adam_learning_rate = 0.02;
  o.search.gradient_tolerance_per_row = 3e-4;
  o.search.restarts = 2;
  o.search.restart_spread = 0.5;
  o.search.seed = 11;
  o.search.start_screening_evaluations = 7;
  o.search.hyperparameter_rows = 250;
  o.search.min_noise_fraction = 1e-6;
  o.gp.scaling = OutputScaling::Center;
  o.gp.mean = MeanKind::Linear;
  o.gp.prior = parse_hyperparameter_prior("lognormal", 1.25);
  o.gp.warm_start_rows = 40;
  o.sparse.inducing_points = 30;
  o.sparse.hyperparameter_objective = parse_hyperparameter_objective("exact");
  o.serial_chain = false;
  o.robot_prior.friction = true;
  o.nn.hidden = {8, 4};
  o.nn.epochs = 3;
  o.nn.batch_size = 16;
  o.nn.learning_rate = 0.005;
  o.nn.validation_fraction = 0.3;
  o.nn.patience = 7;
  o.nn.seed = 4;
  o.chain.starts = 5;
  o.chain.rows = 50;
  o.chain.length_scale = 0.9;
  o.chain.seed = 6;
  const EstimatorOptions back = options_from_record(nlohmann::json::parse(options_record(o).dump()));
  EXPECT_EQ(options_record(back), options_record(o));
  EXPECT_EQ(back.search.optimizer.kind, OptimizerKind::Adam);
  EXPECT_EQ(back.gp.mean, MeanKind::Linear);
  EXPECT_TRUE(back.gp.prior.enabled);
  EXPECT_EQ(back.gp.prior.width, 1.25);
  EXPECT_EQ(back.nn.hidden, (std::vector<int>{8, 4}));
  EXPECT_EQ(back.search.restart_spread, 0.5);
  EXPECT_EQ(back.nn.validation_fraction, 0.3);
  EXPECT_EQ(back.nn.patience, 7);
  // An older record lacks fields: the defaults fill them, but for early stopping, which a network of a record
  // written before it existed did not have.
  EXPECT_EQ(options_record(options_from_record(nlohmann::json{{"estimator", "rbf"}})), options_record([] {
              EstimatorOptions d;
              d.name = "rbf";
              d.nn.validation_fraction = 0.0;
              return d;
            }()));
  EXPECT_NE(error_of([] { options_from_record(nlohmann::json{{"search", {{"restarts", "two"}}}}); })
                .find("search.restarts is not of its type"),
            std::string::npos);
  EXPECT_THROW(options_from_record(nlohmann::json{{"gp", {{"mean", "cubic"}}}}), Error);
  // A fit records them, and a model file keeps them.
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = test::random_inputs(joints, 30, 5);
  const Eigen::MatrixXd Y = test::random_matrix(30, 2, -1.0, 1.0, 6);
  EstimatorOptions fit_options;
  fit_options.name = "rbf";
  fit_options.search.optimizer.max_iterations = 4;
  fit_options.search.seed = 9;
  const FitResult r = fit_estimator(fit_options, X, Y, joints);
  ASSERT_TRUE(r.estimator && r.estimator->options_record());
  EXPECT_EQ(*r.estimator->options_record(), options_record(fit_options));
  const std::filesystem::path path = std::filesystem::temp_directory_path() / "gipdyn_options_record.gipdyn";
  save_estimator(*r.estimator, path.string());
  const std::unique_ptr<Estimator> loaded = load_estimator(path.string());
  std::filesystem::remove(path);
  ASSERT_TRUE(loaded->options_record());
  EXPECT_EQ(options_from_record(*loaded->options_record()).search.seed, 9u);
  // The record holds the starts the fit ran, the table's where the options left them unset.
  EXPECT_EQ(options_from_record(*loaded->options_record()).search.restarts, estimator_spec("rbf").restarts);
}

// Where the options leave the restarts unset, each estimator's search runs its table row's (rbf: restarts
// at a wider spread, since its NLL has optima far from the data-driven start); given ones win.
TEST(EstimatorSearch, UnsetRestartsAreTheEstimatorsOwnAndGivenOnesWin) {
  const EstimatorSpec& rbf = estimator_spec("rbf");
  ASSERT_GT(rbf.restarts, 0);
  ASSERT_EQ(estimator_spec(default_estimator_name()).restarts, 0);
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = test::random_inputs(joints, 40, 5);
  const Eigen::MatrixXd Y = test::random_matrix(40, 2, -1.0, 1.0, 6);
  auto starts_run = [&](const std::string& name, std::optional<int> restarts) {
    EstimatorOptions o;
    o.name = name;
    o.search.optimizer.max_iterations = 5;
    o.search.restarts = restarts;
    const FitResult r = fit_estimator(o, X, Y, joints);
    EXPECT_TRUE(r.report.ok()) << r.report.message;
    return r.report.joints.empty() ? size_t{0} : r.report.joints[0].restart_nlls.size();
  };
  EXPECT_EQ(starts_run("rbf", std::nullopt), static_cast<size_t>(1 + rbf.restarts));
  EXPECT_EQ(starts_run("rbf", 1), size_t{2});
  EXPECT_EQ(starts_run("gip", std::nullopt), size_t{1});
  // The spread too: unset, the row's; a search outside the table (train_model) has none and spread 1.
  EstimatorOptions o;
  o.name = "rbf";
  EXPECT_EQ(o.train_options().search.restart_spread, rbf.restart_spread);
  o.search.restart_spread = 0.25;
  EXPECT_EQ(o.train_options().search.restart_spread, 0.25);
  EXPECT_EQ(SearchSettings{}.restart_count(), 0);
  EXPECT_EQ(SearchSettings{}.restart_spread_or_default(), 1.0);
}
