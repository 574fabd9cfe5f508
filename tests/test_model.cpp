// Inverse dynamics model: the RKHS claim in practice, training determinism,
// model files (round trip, truncation, corruption, versions) and CSV input errors.
#include <gtest/gtest.h>

#include <functional>
#include <thread>
#include <set>
#include <map>
#include <mutex>
#include <atomic>

#include <cstdio>
#include <cstring>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <iterator>
#if defined(__x86_64__) || defined(__SSE2__)
#include <xmmintrin.h>
#endif

#include "gipdyn/error.hpp"
#include "gipdyn/io/detail/atomic_file.hpp"
#include "gipdyn/io/csv.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/model/model_file.hpp"
#include "gipdyn/memory.hpp"
#include "gipdyn/parallel_tasks.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/model/fit_report.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/training_data.hpp"
#include "gipdyn/version.hpp"
#include "gipdyn/progress.hpp"
#include "test_util.hpp"
#include "gipdyn/io/detail/model_container.hpp"

namespace gipdyn {
namespace {

namespace fs = std::filesystem;
using test::error_of;
using test::random_inputs;
using test::two_link_torques;

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / ("gipdyn_test_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

// Writes text, byte for byte, to NAME in temp_dir(); returns its path.
std::string write_text_file(const std::string& name, const std::string& text) {
  const fs::path path = temp_dir() / name;
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

InverseDynamicsModel small_model(const std::string& kernel, int rows, unsigned seed, int max_iter = 40,
                                 MeanKind mean = MeanKind::Zero) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, rows, seed);
  TrainOptions o;
  o.kernel = kernel;
  o.gp.mean = mean;
  o.search.optimizer.max_iterations = max_iter;
  // Measurement noise keeps the model well conditioned, as on real data; with
  // noise-free data the noise variance sits at its floor and alpha is huge.
  const Eigen::MatrixXd Y = two_link_torques(X) + 0.01 * test::random_matrix(rows, 2, -1.0, 1.0, 909);
  TrainResult r = train_model(X, Y, joints, o);
  EXPECT_TRUE(r.report.ok()) << r.report.message;
  return std::move(r.model);
}

// The exact rigid-body dynamics lies in the GIP kernel's RKHS: 300 noise-free
// samples of a 2R arm are enough for GIP, not for RBF.
TEST(RkhsClaim, GipLearnsTwoLinkDynamicsFrom300SamplesAndRbfDoesNot) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd Xtr = random_inputs(joints, 300, 41), Xte = random_inputs(joints, 500, 42);
  const Eigen::MatrixXd Ytr = two_link_torques(Xtr), Yte = two_link_torques(Xte);
  TrainOptions o;
  o.kernel = "gip";
  const TrainResult gip = train_model(Xtr, Ytr, joints, o);
  ASSERT_TRUE(gip.report.ok()) << gip.report.message;
  const Accuracy a = compute_accuracy(Yte, gip.model.predict(Xte));
  EXPECT_LT(a.nmse.maxCoeff(), 1e-4) << "GIP nMSE " << a.nmse.transpose();
  o.kernel = "rbf";
  const TrainResult rbf = train_model(Xtr, Ytr, joints, o);
  ASSERT_TRUE(rbf.report.ok()) << rbf.report.message;
  const Accuracy b = compute_accuracy(Yte, rbf.model.predict(Xte));
  EXPECT_GT(b.nmse.mean(), 1e-4) << "RBF nMSE " << b.nmse.transpose();
  EXPECT_GT(b.nmse.mean(), 100 * a.nmse.mean());
}

TEST(Training, SameSeedSameModelWhateverTheThreads) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, 60, 43);
  const Eigen::MatrixXd Y = two_link_torques(X) + 0.01 * test::random_matrix(60, 2, -1.0, 1.0, 910);
  TrainOptions o;
  o.search.optimizer.max_iterations = 30;
  o.search.restarts = 2;
  o.search.seed = 5;
  o.search.threads = 1;
  const TrainResult a = train_model(X, Y, joints, o);
  o.search.threads = 2;
  const TrainResult b = train_model(X, Y, joints, o);
  ASSERT_TRUE(a.report.ok() && b.report.ok());
  for (int j = 0; j < 2; ++j) {
    EXPECT_EQ(a.model.joint_gp(j).kernel().log_params(), b.model.joint_gp(j).kernel().log_params());
    EXPECT_EQ(a.report.joints[static_cast<size_t>(j)].restart_nlls.size(), 3u);
  }
  o.search.seed = 6;
  const TrainResult c = train_model(X, Y, joints, o);
  EXPECT_NE(a.report.joints[0].restart_nlls[1], c.report.joints[0].restart_nlls[1]);  // restarts depend on the seed
}

// By default every joint trains at once, on its own thread, whatever the core
// count: more joints than cores share them, so that no core waits while the
// longest joint finishes. On the 2-core CI machine the old rule (one thread
// per core) would run three joints on two threads.
TEST(Training, EveryJointTrainsAtOnceByDefault) {
  const JointTypes joints = JointTypes::parse("RRR");
  const Eigen::MatrixXd X = random_inputs(joints, 300, 44);
  const Eigen::MatrixXd Y = test::random_matrix(300, 3, -1.0, 1.0, 911);
  TrainOptions o;
  o.search.optimizer.max_iterations = 30;
  std::mutex m;
  std::map<int, std::set<std::thread::id>> threads_of_joint;
  const TrainResult a = train_model(X, Y, joints, o, [&](const ProgressEvent& e) {
    const std::lock_guard<std::mutex> lock(m);
    if (e.joint >= 0) threads_of_joint[e.joint].insert(std::this_thread::get_id());
  });
  ASSERT_TRUE(a.report.ok()) << a.report.message;
  std::set<std::thread::id> all;
  for (const auto& [joint, ids] : threads_of_joint) {
    EXPECT_EQ(ids.size(), 1u) << "joint " << joint;
    all.insert(ids.begin(), ids.end());
  }
  EXPECT_EQ(threads_of_joint.size(), 3u);
  EXPECT_EQ(all.size(), 3u);
  EXPECT_EQ(gipdyn::sharing_threads(0, 6), 6);
  EXPECT_EQ(gipdyn::sharing_threads(2, 6), 2);
  // The same model as one joint after another.
  o.search.threads = 1;
  const TrainResult b = train_model(X, Y, joints, o);
  for (int j = 0; j < 3; ++j)
    EXPECT_EQ(a.model.joint_gp(j).kernel().log_params(), b.model.joint_gp(j).kernel().log_params());
}

// What a front end is told about the joints in flight (for its time estimates)
// is what training does: every joint at once by default, the threads asked
// for, and one at a time where two joints' N x N matrices would not fit.
TEST(Training, SaysHowManyJointsTrainAtOnce) {
  TrainOptions o;
  EXPECT_EQ(joints_trained_at_once(o, 300, 3), 3);
  o.search.threads = 2;
  EXPECT_EQ(joints_trained_at_once(o, 300, 3), 2);
  o.search.threads = 0;
  // Two N x N matrices a joint: at this N one joint takes two thirds of the memory.
  const double available = static_cast<double>(gipdyn::available_memory_bytes());
  const auto rows = static_cast<Eigen::Index>(std::sqrt(available / 1.5 / 16.0));
  EXPECT_EQ(joints_trained_at_once(o, rows, 3), 1);
  EXPECT_EQ(joints_trained_at_once(o, rows / 4, 3), 3);  // a sixteenth of it each
}

#if defined(__x86_64__) || defined(__SSE2__)
// Training flushes subnormal numbers to zero on its threads (they made NLL
// evaluations with tiny lengthscales 16x slower) and must hand the caller's
// floating-point mode back untouched, also when it throws.
TEST(Training, LeavesTheCallersFloatingPointModeAsItWas) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, 40, 44);
  const Eigen::MatrixXd Y = two_link_torques(X);
  TrainOptions o;
  o.search.optimizer.max_iterations = 10;
  o.search.threads = 1;
  const unsigned before = _mm_getcsr();
  ASSERT_EQ(before & 0x8040u, 0u);
  EXPECT_TRUE(train_model(X, Y, joints, o).report.ok());
  EXPECT_EQ(_mm_getcsr(), before);
  Eigen::MatrixXd bad = Y;
  bad(3, 1) = std::nan("");
  EXPECT_THROW(train_model(X, bad, joints, o), Error);
  EXPECT_EQ(_mm_getcsr(), before);
}

// Prediction flushes them too (a query of an RBF model trained on real UR10
// rows took 5x longer without), on the caller's own thread: every entry point
// must restore the caller's mode, also when it throws.
TEST(Prediction, LeavesTheCallersFloatingPointModeAsItWas) {
  const InverseDynamicsModel m = small_model("rbf", 30, 50, 5);
  const JointTypes joints = m.joints();
  const Eigen::MatrixXd X = random_inputs(joints, 3, 51);
  const unsigned before = _mm_getcsr();
  ASSERT_EQ(before & 0x8040u, 0u);
  const Eigen::MatrixXd batch = m.predict(X);
  EXPECT_EQ(_mm_getcsr(), before);
  PredictionWorkspace ws(m);
  EXPECT_EQ(_mm_getcsr(), before);
  Eigen::VectorXd x = X.row(0).transpose(), tau(m.num_joints()), sd(m.num_joints());
  ws.predict(x.data(), tau.data());
  EXPECT_EQ(_mm_getcsr(), before);
  for (int j = 0; j < m.num_joints(); ++j) EXPECT_NEAR(tau(j), batch(0, j), 1e-12 * (1.0 + std::abs(batch(0, j))));
  ASSERT_TRUE(m.has_variance());
  ws.predict(x.data(), tau.data(), sd.data());
  EXPECT_EQ(_mm_getcsr(), before);
  Eigen::MatrixXd mean, stddev;
  m.predict(X, mean, &stddev);
  EXPECT_EQ(_mm_getcsr(), before);
  EXPECT_THROW(m.predict(Eigen::MatrixXd::Zero(2, 5)), Error);  // wrong column count
  EXPECT_EQ(_mm_getcsr(), before);
}
#endif

TEST(Training, AdamLowersTheNll) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, 50, 44);
  TrainOptions o;
  o.search.optimizer.kind = OptimizerKind::Adam;
  o.search.optimizer.max_iterations = 60;
  o.search.optimizer.adam_learning_rate = 0.05;
  std::vector<double> first(2, 0.0);
  ProgressCallback cb = [&](const ProgressEvent& p) {
    if (p.iteration == 1 && !p.finished) first[static_cast<size_t>(p.joint)] = p.objective;
  };
  o.search.threads = 1;
  const TrainResult r = train_model(X, two_link_torques(X), joints, o, cb);
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  for (int j = 0; j < 2; ++j) EXPECT_LT(r.report.joints[static_cast<size_t>(j)].nll, first[static_cast<size_t>(j)] - 10.0);
}

TEST(Training, ReportsEachJointsStopAndWarnsAboutTheCap) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, 40, 44);
  const Eigen::MatrixXd Y = two_link_torques(X) + 0.01 * test::random_matrix(40, 2, -1.0, 1.0, 911);
  TrainOptions o;
  o.search.optimizer.max_iterations = 3;  // far too few: every joint stops at the cap
  const TrainResult r = train_model(X, Y, joints, o);
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  EXPECT_EQ(r.report.status, FitStatus::NotConverged);
  ASSERT_EQ(r.report.joints.size(), 2u);
  for (int j = 0; j < 2; ++j) {
    const JointReport& jr = r.report.joints[static_cast<size_t>(j)];
    EXPECT_EQ(jr.status, OptimizerResult::Status::MaxIterations);
    EXPECT_EQ(jr.evaluations, 3);
    EXPECT_GT(jr.grad_norm, 0.0);
    // The reported noise is the model's own.
    EXPECT_DOUBLE_EQ(jr.noise_variance, std::exp(r.model.joint_gp(j).log_noise_variance()));
  }
  const auto warnings = r.report.warnings();
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings[0].find("joint(s) 1, 2"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("OptimizerOptions::max_iterations"), std::string::npos) << warnings[0];
  EXPECT_NE(r.report.brief_report().find("max-iter"), std::string::npos);
}

TEST(Training, NamesJointsWhoseFitCallsTheTorqueNoise) {
  // Joint 2's torque shrunk far below the noise: its fit explains it as noise. Unscaled outputs, so the
  // share is the noise variance over the mean square of the torque itself, not the noise variance.
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = random_inputs(joints, 80, 48);
  Eigen::MatrixXd Y = two_link_torques(X);
  Y.col(1) *= 1e-3;
  Y += 0.05 * test::random_matrix(80, 2, -1.0, 1.0, 49);
  TrainOptions o;
  o.gp.scaling = OutputScaling::None;
  const TrainResult r = train_model(X, Y, joints, o);
  ASSERT_TRUE(r.report.ok()) << r.report.message;
  for (int j = 0; j < 2; ++j) {
    const JointReport& jr = r.report.joints[static_cast<size_t>(j)];
    EXPECT_NEAR(jr.noise_share, jr.noise_variance / Y.col(j).squaredNorm() * 80.0, 1e-12 * jr.noise_share);
  }
  EXPECT_LT(r.report.joints[0].noise_share, 0.01);
  EXPECT_GE(r.report.joints[1].noise_share, kNoiseShareWarning);
  std::vector<std::string> noisy;
  for (const std::string& w : r.report.warnings())
    if (w.find("calls most of the torque noise") != std::string::npos) noisy.push_back(w);
  ASSERT_EQ(noisy.size(), 1u);
  EXPECT_EQ(noisy[0].rfind("joint(s) 2 (", 0), 0u) << noisy[0];
}

// A jitter is extra noise: far above the noise the fit learned, the model no
// longer fits its rows (pp on a UR10 before its variances were capped: jitter
// 8.7 against a noise variance of 5e-8, and joint 2 tested at nMSE 2e-4 where
// it reaches 3e-9). The warning says so; a jitter below the noise does not.
TEST(FitReport, SaysWhenTheJitterSmoothsTheModelBeyondItsNoise) {
  FitReport report;
  report.joints.resize(2);
  for (int j = 0; j < 2; ++j) {
    report.joints[static_cast<size_t>(j)].joint = j;
    report.joints[static_cast<size_t>(j)].status = OptimizerResult::Status::Converged;
    report.joints[static_cast<size_t>(j)].noise_variance = 1e-4;
  }
  report.joints[0].jitter = 1e-6;
  report.joints[1].jitter = 8.7;
  std::vector<std::string> jitter;
  for (const std::string& w : report.warnings())
    if (w.find("jitter") != std::string::npos) jitter.push_back(w);
  ASSERT_EQ(jitter.size(), 2u);
  EXPECT_EQ(jitter[0].rfind("joint 1 needed a jitter of 1e-06", 0), 0u) << jitter[0];
  EXPECT_EQ(jitter[0].find("smoothed"), std::string::npos) << jitter[0];
  EXPECT_EQ(jitter[1].rfind("joint 2 needed a jitter of 8.7 on the kernel diagonal, 8.7e+04 times the noise", 0), 0u)
      << jitter[1];
  EXPECT_NE(jitter[1].find("smoothed more than its data ask"), std::string::npos) << jitter[1];
  EXPECT_NE(jitter[1].find("SearchSettings::min_noise_fraction"), std::string::npos) << jitter[1];
}

TEST(Training, RejectsBadData) {
  const JointTypes joints = JointTypes::parse("RR");
  Eigen::MatrixXd X = random_inputs(joints, 20, 45);
  Eigen::MatrixXd Y = two_link_torques(X);
  TrainOptions o;
  EXPECT_NE(error_of([&] { train_model(X.leftCols(5), Y, joints, o); }).find("need 6"), std::string::npos);
  EXPECT_NE(error_of([&] { train_model(X.topRows(3), Y.topRows(3), joints, o); }).find("at least"), std::string::npos);
  X(3, 2) = std::nan("");
  EXPECT_NE(error_of([&] { train_model(X, Y, joints, o); }).find("NaN"), std::string::npos);
  o.kernel = "nope";
  EXPECT_NE(error_of([&] { o.validate(); }).find("unknown kernel"), std::string::npos);
}

// The library names its own fields, never a front end's flags; front ends rename them.
TEST(Training, OptionErrorsNameTheFieldAndFrontEndsRenameIt) {
  struct Case {
    std::function<void(TrainOptions&)> spoil;
    std::string field;
  };
  const std::vector<Case> cases{
      {[](TrainOptions& o) { o.search.restarts = -1; }, "SearchSettings::restarts"},
      {[](TrainOptions& o) { o.search.min_noise_fraction = -1; }, "SearchSettings::min_noise_fraction"},
      {[](TrainOptions& o) { o.search.threads = -2; }, "SearchSettings::threads"},
      {[](TrainOptions& o) { o.search.optimizer.max_iterations = 0; }, "OptimizerOptions::max_iterations"},
      {[](TrainOptions& o) { o.search.optimizer.lbfgs_memory = 0; }, "OptimizerOptions::lbfgs_memory"},
      {[](TrainOptions& o) { o.gp.prior.width = 0; }, "HyperparameterPrior::width"},
      {[](TrainOptions& o) { o.kernel = "pp"; }, "TrainOptions::robot_prior"},
  };
  for (const auto& c : cases) {
    TrainOptions o;
    c.spoil(o);
    const std::string message = error_of([&] { o.validate(); });
    EXPECT_NE(message.find(c.field), std::string::npos) << message;
    EXPECT_EQ(message.find("--"), std::string::npos) << message;
  }
  const FieldNames cli{{"SearchSettings::min_noise_fraction", "--min-noise"},
                       {"SearchSettings::initial_noise_fraction", "--initial-noise"},
                       {"TrainOptions::min", "WRONG"}};
  TrainOptions o;
  o.search.min_noise_fraction = 0.5;  // above the initial fraction: the message names both fields
  EXPECT_EQ(rename_fields(error_of([&] { o.validate(); }), cli),
            "--min-noise must be > 0 and not above --initial-noise (0.010000)");
  // A replacement is never rewritten again, even when it contains another field's name.
  EXPECT_EQ(rename_fields("a.b and b", {{"a.b", "b.c"}, {"b", "x"}}), "b.c and x");
}

TEST(Training, ConstantStepSubsample) {
  const auto idx = constant_step_indices(40000, 4000);
  ASSERT_EQ(idx.size(), 4000u);
  EXPECT_EQ(idx[1], 10);
  EXPECT_EQ(idx.back(), 39990);
  EXPECT_EQ(constant_step_indices(7, 3), (std::vector<Eigen::Index>{0, 2, 4}));
  EXPECT_EQ(constant_step_indices(5, 10).size(), 5u);
}

TEST(InputBox, SaturatesEverythingButRevolutePositionsIntoTheWidenedBox) {
  const JointTypes joints = JointTypes::parse("RP");
  Eigen::MatrixXd train(2, 6);
  train << 0, 0.1, -1, -2, -3, -4,
           1, 0.3, 1, 2, 3, 4;
  const InputBox box = InputBox::of(train);
  Eigen::MatrixXd X(3, 6);
  X << 5, 0.2, 0, 0, 0, 0,     // revolute q far out: not checked
       0, 0.5, 1.1, 0, 0, 0,   // prismatic q and qd1 out
       0, 0.2, 0, 0, 0, -9;    // qdd2 out
  EXPECT_EQ(box.rows_outside(X, joints, 0.0), 2);
  EXPECT_EQ(box.rows_outside(X, joints, 0.1), 2);  // qd1 1.1 is inside 1 + 0.1 x 2, the others are not
  Eigen::MatrixXd Y = X;
  EXPECT_EQ(box.saturate(Y, joints, 0.1), 2);
  EXPECT_EQ(Y(0, 0), 5.0);
  EXPECT_DOUBLE_EQ(Y(1, 1), 0.32);  // 0.3 + 0.1 x 0.2
  EXPECT_EQ(Y(1, 2), 1.1);
  EXPECT_DOUBLE_EQ(Y(2, 5), -4.8);
  EXPECT_EQ(box.rows_outside(Y, joints, 0.1), 0);
  EXPECT_THROW(box.saturate(Y, joints, -0.1), Error);
  EXPECT_THROW(box.saturate(Y, JointTypes::parse("R"), 0.1), Error);

  // The warning counts the rows out of the box widened by half of each range and names the farthest column:
  // q2 = 0.5 is 0.1 beyond 0.3 + 0.5 x 0.2, half its range; qdd2 = -9 is 1 beyond -4 - 0.5 x 8, an eighth of its.
  const std::string warning = extrapolation_warning(box, X, joints, "'t.csv'", 0.5);
  EXPECT_EQ(warning.rfind("2 of 3 rows of 't.csv' lie outside the box of the model's training inputs (velocities, "
                          "accelerations and prismatic positions, widened by 50 % of each range), q2 farthest (0.5 "
                          "training ranges beyond it): predictions there are extrapolation",
                          0),
            0u)
      << warning;
  EXPECT_EQ(extrapolation_warning(box, X, joints, "'t.csv'", 1.0), "");  // q2 then reaches 0.5 exactly
  X(1, 1) = 0.2;
  EXPECT_NE(extrapolation_warning(box, X, joints, "X", 0.5).find("1 of 3 rows of X lie outside"), std::string::npos);
  EXPECT_NE(extrapolation_warning(box, X, joints, "X", 0.5).find("qdd2 farthest (0.12 training ranges"),
            std::string::npos);
}

TEST(Training, ShiftedConstantStepSubsamplesInterleave) {
  // Three shifts of 4 rows out of 12: disjoint, together every row once, each in range and increasing.
  std::vector<int> seen(12, 0);
  for (Eigen::Index shift = 0; shift < 3; ++shift) {
    const auto idx = constant_step_indices(12, 4, shift, 3);
    ASSERT_EQ(idx.size(), 4u);
    for (size_t k = 0; k < idx.size(); ++k) {
      ++seen[static_cast<size_t>(idx[k])];
      if (k > 0) {
        EXPECT_GT(idx[k], idx[k - 1]);
      }
    }
  }
  EXPECT_EQ(seen, std::vector<int>(12, 1));
  EXPECT_EQ(constant_step_indices(40000, 4000, 0, 5), constant_step_indices(40000, 4000));
  EXPECT_EQ(constant_step_indices(6340, 1000, 4, 5).back(), 6338);  // never past the last row
  EXPECT_THROW(constant_step_indices(10, 5, 3, 3), Error);
  EXPECT_THROW(constant_step_indices(10, 5, 0, 0), Error);
}

TEST(ModelFile, SaveLoadPredictIsBitIdentical) {
  for (const auto& [kernel, mean] : {std::pair{"gip", MeanKind::Zero}, std::pair{"gip-friction", MeanKind::Zero},
                                     std::pair{"rbf", MeanKind::Zero}, std::pair{"gip", MeanKind::Linear},
                                     std::pair{"rbf", MeanKind::Constant}, std::pair{"gip+rbf", MeanKind::Zero},
                                     std::pair{"gip-envelope+friction", MeanKind::Zero},
                                     std::pair{"gip+friction", MeanKind::Linear}}) {
    InverseDynamicsModel m = small_model(kernel, 40, 46, 40, mean);
    const fs::path path = temp_dir() / (std::string(kernel) + "_" + to_string(mean) + ".gipdyn");
    save_model(m, path.string());
    InverseDynamicsModel loaded = load_model(path.string());
    const Eigen::MatrixXd Xq = random_inputs(m.joints(), 25, 47);
    const Eigen::MatrixXd a = m.predict(Xq), b = loaded.predict(Xq);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<size_t>(a.size())), 0) << kernel;
    EXPECT_EQ(loaded.kernel_name(), kernel);
    EXPECT_EQ(loaded.mean_kind(), mean);
    EXPECT_EQ(loaded.hyperparameters(1), m.hyperparameters(1));
    // How each joint was trained travels with the model.
    ASSERT_EQ(loaded.training_report().size(), 2u) << kernel;
    for (size_t j = 0; j < 2; ++j) {
      const JointReport &a_report = m.training_report()[j], &b_report = loaded.training_report()[j];
      EXPECT_EQ(b_report.status, a_report.status);
      EXPECT_EQ(b_report.evaluations, a_report.evaluations);
      EXPECT_EQ(b_report.grad_norm, a_report.grad_norm);
      EXPECT_EQ(b_report.noise_variance, a_report.noise_variance);
      EXPECT_TRUE(std::isfinite(a_report.noise_share));
      EXPECT_EQ(b_report.noise_share, a_report.noise_share);
      EXPECT_EQ(b_report.nll, a_report.nll);
    }
    // Variance after load (factor recomputed in a new model) matches the trained model's.
    EXPECT_FALSE(loaded.has_variance());
    const InverseDynamicsModel trained_with_variance = m.with_variance(), loaded_with_variance = loaded.with_variance();
    EXPECT_FALSE(loaded.has_variance());  // the loaded model itself is unchanged
    Eigen::MatrixXd ma, sa, mb, sb;
    trained_with_variance.predict(Xq, ma, &sa);
    loaded_with_variance.predict(Xq, mb, &sb);
    EXPECT_EQ(std::memcmp(sa.data(), sb.data(), sizeof(double) * static_cast<size_t>(sa.size())), 0) << kernel;
    // The control-loop path agrees with the batch path up to rounding (the two
    // sum k(x*, X) in different orders; |alpha| amplifies the last bits).
    PredictionWorkspace ws(loaded_with_variance);
    Eigen::VectorXd tau(2), sd(2);
    const Eigen::VectorXd x = Xq.row(3).transpose();
    ws.predict(x.data(), tau.data(), sd.data());
    for (int j = 0; j < 2; ++j) {
      EXPECT_NEAR(tau(j), mb(3, j), 1e-7 * (1 + std::abs(mb(3, j))) + test::prediction_rounding(loaded, j, x)) << kernel;
      EXPECT_NEAR(sd(j), sb(3, j), 1e-5 * sb(3, j) + 1e-9) << kernel;
    }
    // The mean alone takes the planned path (friction folded into its weights).
    ws.predict(x.data(), tau.data());
    for (int j = 0; j < 2; ++j)
      EXPECT_NEAR(tau(j), mb(3, j), 1e-7 * (1 + std::abs(mb(3, j))) + test::prediction_rounding(loaded, j, x)) << kernel;
  }
}

// Rigid-body dynamics plus what the polynomial space cannot hold (a smooth
// Coulomb-like friction and a position-dependent ripple, as on real arms): GIP
// alone misses the disturbance, RBF alone needs far more data for the rigid
// body, and the hybrid GIP + RBF, trained jointly, beats both.
TEST(HybridKernel, BeatsGipAndRbfOnRigidBodyPlusDisturbance) {
  const JointTypes joints = JointTypes::parse("RR");
  auto torques = [](const Eigen::MatrixXd& X) {
    Eigen::MatrixXd tau = two_link_torques(X);
    for (int j = 0; j < 2; ++j)
      tau.col(j).array() += 0.3 * ((4.0 * X.col(2 + j).array()).tanh() + (3.0 * X.col(j).array()).sin());
    return tau;
  };
  // Joint ranges of a real arm: q in [-3, 3] rad, qd in [-2, 2] rad/s, qdd in [-5, 5] rad/s^2.
  const Eigen::RowVectorXd range = (Eigen::RowVectorXd(6) << 3, 3, 2, 2, 5, 5).finished();
  const Eigen::MatrixXd Xtr = random_inputs(joints, 300, 81).array().rowwise() * range.array(),
                        Xte = random_inputs(joints, 1000, 82).array().rowwise() * range.array();
  const Eigen::MatrixXd Ytr = torques(Xtr) + 0.01 * test::random_vector(300, -1, 1, 83).replicate(1, 2),
                        Yte = torques(Xte);
  Eigen::VectorXd nmse(3);
  const char* kernels[] = {"gip", "rbf", "gip+rbf"};
  for (int k = 0; k < 3; ++k) {
    TrainOptions o;
    o.kernel = kernels[k];
    const TrainResult r = train_model(Xtr, Ytr, joints, o);
    ASSERT_TRUE(r.report.ok()) << r.report.message;
    nmse(k) = compute_accuracy(Yte, r.model.predict(Xte)).nmse.mean();
  }
  std::printf("mean nMSE: gip %.3g, rbf %.3g, gip+rbf %.3g\n", nmse(0), nmse(1), nmse(2));
  EXPECT_LT(nmse(2), 0.5 * nmse(0));
  EXPECT_LT(nmse(2), 0.5 * nmse(1));
}

// The envelope (gip-envelope, EnvelopeKernel) bounds what GIP predicts away
// from its data without costing accuracy near it: on a 2-link arm with a
// disturbance outside GIP's space, in-range test error stays within 1.5x of
// GIP's; far outside the training inputs the prediction returns to the prior
// mean (the scaled output's mean) and its standard deviation to the prior's,
// where GIP's polynomial keeps growing.
TEST(EnvelopeKernel, KeepsInRangeAccuracyAndRevertsToThePriorFarAway) {
  const JointTypes joints = JointTypes::parse("RR");
  auto torques = [](const Eigen::MatrixXd& X) {
    Eigen::MatrixXd tau = two_link_torques(X);
    for (int j = 0; j < 2; ++j) tau.col(j).array() += 0.3 * (4.0 * X.col(2 + j).array()).tanh();
    return tau;
  };
  const Eigen::MatrixXd Xtr = random_inputs(joints, 300, 91), Xte = random_inputs(joints, 500, 92);
  const Eigen::MatrixXd Ytr = torques(Xtr) + 0.01 * test::random_vector(300, -1, 1, 93).replicate(1, 2);
  TrainOptions o;
  o.gp.keep_factor = true;
  o.kernel = "gip";
  const TrainResult gip = train_model(Xtr, Ytr, joints, o);
  o.kernel = "gip-envelope";
  const TrainResult env = train_model(Xtr, Ytr, joints, o);
  ASSERT_TRUE(gip.report.ok() && env.report.ok()) << gip.report.message << env.report.message;
  // Far: every velocity and acceleration 10 of the envelope's learned lengthscales
  // (the longer of the two joints') out. Maximum likelihood may lengthen a scale
  // without bound: the envelope then bounds nothing along that input.
  const FeatureMap& fm = env.model.features();
  Eigen::RowVectorXd scale = Eigen::RowVectorXd::Zero(6);
  for (int j = 0; j < 2; ++j)
    for (const auto& [name, value] : env.model.hyperparameters(j))
      for (int c = 2; c < 6; ++c)
        if (name == "envelope.lengthscale_" + fm.name(c)) scale(c) = std::max(scale(c), value);
  Eigen::MatrixXd far = random_inputs(joints, 50, 94);
  for (int c = 2; c < 6; ++c) far.col(c) = far.col(c).array().sign() * 10.0 * scale(c);
  const double longest = scale.maxCoeff();
  const Eigen::VectorXd near_gip = compute_accuracy(torques(Xte), gip.model.predict(Xte)).nmse;
  const Eigen::VectorXd near_env = compute_accuracy(torques(Xte), env.model.predict(Xte)).nmse;
  Eigen::MatrixXd mean, stddev;
  env.model.predict(far, mean, &stddev);
  const Eigen::MatrixXd gip_far = gip.model.predict(far);
  std::printf("in range: nMSE gip %.3g %.3g, gip-envelope %.3g %.3g; longest lengthscale %.3g; 10 lengthscales "
              "out: max |tau| gip %.3g, gip-envelope %.3g\n",
              near_gip(0), near_gip(1), near_env(0), near_env(1), longest, gip_far.cwiseAbs().maxCoeff(),
              mean.cwiseAbs().maxCoeff());
  for (int j = 0; j < 2; ++j) {
    EXPECT_LT(near_env(j), 1.5 * near_gip(j) + 1e-4) << "joint " << j + 1;
    // Scaled outputs are standardised: the prior is the training mean with the training spread.
    const double y_mean = Ytr.col(j).mean();
    const double y_std = std::sqrt((Ytr.col(j).array() - y_mean).square().mean());
    EXPECT_LT((mean.col(j).array() - y_mean).abs().maxCoeff(), 0.05 * y_std) << "joint " << j + 1;
    KernelScratch scratch;
    const double prior_std =
        env.model.output_scale()(j) * std::sqrt(env.model.joint_gp(j).kernel().self(
                                          env.model.features().compute(far.row(0)).data(),
                                          env.model.features().feature_dim(), scratch));
    EXPECT_NEAR(stddev(0, j), prior_std, 0.05 * prior_std) << "joint " << j + 1;
    EXPECT_GT(gip_far.col(j).cwiseAbs().maxCoeff(), 10.0 * Ytr.col(j).cwiseAbs().maxCoeff());  // the polynomial runs away
  }
}

// A mean function decides what a GP predicts away from its data: a local (RBF)
// GP reverts to its prior mean. On a linear trend the linear mean extrapolates
// the trend, the constant mean levels off at the data's level, and the zero
// mean falls back to zero; the fitted coefficients recover the trend.
TEST(MeanFunction, DecidesTheExtrapolationOfALocalKernel) {
  const JointTypes joints = JointTypes::parse("R");
  const Eigen::MatrixXd X = random_inputs(joints, 200, 71);
  // A trend plus an even wiggle in every input: the wiggles keep every RBF length
  // scale short, so far from the data the RBF part has decayed to nothing.
  const Eigen::ArrayXd q = X.col(0).array(), qd = X.col(1).array(), qdd = X.col(2).array();
  const Eigen::MatrixXd Y =
      (5.0 + 2.0 * q - 1.5 * qdd + (3.0 * q).cos() + (3.0 * qd).cos() + (3.0 * qdd).cos()).matrix() +
      0.01 * test::random_vector(200, -1, 1, 72);
  Eigen::MatrixXd far = Eigen::MatrixXd::Zero(1, 3);
  far << 8.0, 8.0, -8.0;  // far outside [-1, 1]^3
  const double wiggles = 3.0 * std::sin(3.0) / 3.0;  // their mean over U[-1, 1]
  const double truth = 5.0 + wiggles + 2.0 * 8.0 + 1.5 * 8.0;
  auto fit = [&](MeanKind mean) {
    TrainOptions o;
    o.kernel = "rbf";
    o.gp.scaling = OutputScaling::None;
    o.gp.mean = mean;
    TrainResult r = train_model(X, Y, joints, o);
    EXPECT_TRUE(r.report.ok()) << r.report.message;
    return std::move(r.model);
  };
  const InverseDynamicsModel linear = fit(MeanKind::Linear), constant = fit(MeanKind::Constant),
                             zero = fit(MeanKind::Zero);
  EXPECT_NEAR(linear.predict(far)(0, 0), truth, 0.05 * truth);
  const Eigen::VectorXd beta = linear.joint_mean(0).params();
  EXPECT_NEAR(beta(1), 2.0, 0.1);
  EXPECT_NEAR(beta(3), -1.5, 0.1);
  EXPECT_NEAR(constant.predict(far)(0, 0), Y.mean(), 0.5);
  EXPECT_NEAR(zero.predict(far)(0, 0), 0.0, 1.0);
  // The control-loop path adds the mean too.
  PredictionWorkspace ws(linear);
  double tau = 0.0;
  ws.predict(far.data(), &tau);
  EXPECT_NEAR(tau, linear.predict(far)(0, 0), 1e-9 * std::abs(tau));
  EXPECT_THROW(parse_mean_kind("quadratic"), Error);
}

// A GIP model's rigid-body terms come from one pass over its training rows (GipKernel::affine_coefficients):
// they must equal the n + 2 queries that define them, for every GIP-family kernel, prior mean and scaling, and
// for a kernel without the fused path (which answers by those queries).
TEST(PredictionWorkspace, RigidBodyTermsEqualTheQueriesThatDefineThem) {
  const JointTypes joints = JointTypes::parse("RRPR");
  const int n = joints.size();
  const Eigen::MatrixXd X = random_inputs(joints, 60, 71);
  const Eigen::MatrixXd Y = test::random_matrix(60, n, -2.0, 2.0, 72);
  for (const char* kernel : {"gip", "gip-friction", "rbf"})
    for (const MeanKind mean : {MeanKind::Zero, MeanKind::Linear}) {
      TrainOptions o;
      o.kernel = kernel;
      o.gp.mean = mean;
      o.search.optimizer.max_iterations = 8;
      const TrainResult r = train_model(X, Y, joints, o);
      ASSERT_TRUE(r.report.ok()) << r.report.message;
      EXPECT_EQ(r.model.gip_kernels().empty(), std::string(kernel) == "rbf");
      PredictionWorkspace ws(r.model);
      const Eigen::MatrixXd states = random_inputs(joints, 4, 73);
      for (Eigen::Index s = 0; s < states.rows(); ++s) {
        const Eigen::VectorXd q = states.row(s).head(n).transpose(), qd = states.row(s).segment(n, n).transpose();
        Eigen::VectorXd gravity(n), bias(n);
        Eigen::MatrixXd M_rows(n, n);  // row-major: M_rows(j, i) = M(i, j)
        ws.rigid_body_terms(q.data(), qd.data(), gravity.data(), M_rows.data(), bias.data());
        Eigen::MatrixXd queries = Eigen::MatrixXd::Zero(n + 2, 3 * n);
        queries.leftCols(n).rowwise() = q.transpose();
        for (int j = 0; j < n; ++j) queries(1 + j, 2 * n + j) = 1.0;
        queries.row(n + 1).segment(n, n) = qd.transpose();
        const Eigen::MatrixXd tau = r.model.predict(queries);
        const double scale = 1.0 + tau.cwiseAbs().maxCoeff();
        const std::string where = std::string(kernel) + " mean " + to_string(mean) + " state " + std::to_string(s);
        EXPECT_LT((gravity.transpose() - tau.row(0)).cwiseAbs().maxCoeff(), 1e-10 * scale) << where;
        EXPECT_LT((bias.transpose() - tau.row(n + 1)).cwiseAbs().maxCoeff(), 1e-10 * scale) << where;
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i)
            EXPECT_NEAR(M_rows(j, i), tau(1 + j, i) - tau(0, i), 1e-10 * scale) << where << " M(" << i << ", " << j << ")";
      }
    }
}

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const fs::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(s.data(), static_cast<std::streamsize>(s.size()));
}

TEST(ModelFile, RejectsTruncatedCorruptedAndNewerFiles) {
  const InverseDynamicsModel m = small_model("gip", 20, 48, 5);
  const fs::path good = temp_dir() / "good.gipdyn", bad = temp_dir() / "bad.gipdyn";
  save_model(m, good.string());
  const std::string bytes = read_bytes(good);

  for (size_t cut : {size_t{0}, size_t{10}, size_t{30}, bytes.size() / 2, bytes.size() - 1}) {
    write_bytes(bad, bytes.substr(0, cut));
    const std::string msg = error_of([&] { load_model(bad.string()); });
    EXPECT_FALSE(msg.empty()) << "cut at " << cut;
    EXPECT_TRUE(msg.find("truncated") != std::string::npos || msg.find("not a gipdyn model") != std::string::npos ||
                msg.find("corrupted") != std::string::npos)
        << msg;
  }
  write_bytes(bad, bytes.substr(0, bytes.size() - 100));
  EXPECT_NE(error_of([&] { load_model(bad.string()); }).find("truncated"), std::string::npos);

  std::string flipped = bytes;
  flipped[bytes.size() - 50] ^= 0x01;  // a payload bit
  write_bytes(bad, flipped);
  EXPECT_NE(error_of([&] { load_model(bad.string()); }).find("checksum"), std::string::npos);

  std::string header_hit = bytes;
  header_hit[40] = '#';  // inside the JSON header
  write_bytes(bad, header_hit);
  EXPECT_NE(error_of([&] { load_model(bad.string()); }).find("corrupted"), std::string::npos);

  std::string newer = bytes;
  newer[8] = static_cast<char>(kModelFormatVersion + 1);
  write_bytes(bad, newer);
  // The error names the gipdyn that wrote the file (the header records it) and this one.
  const std::string newer_message = error_of([&] { load_model(bad.string()); });
  EXPECT_NE(newer_message.find(", written by gipdyn " + std::string(version()) + ", newer than this gipdyn (" +
                               std::string(version()) + ") reads"),
            std::string::npos)
      << newer_message;

  EXPECT_NE(error_of([&] { load_model((temp_dir() / "missing.gipdyn").string()); }).find("cannot open"),
            std::string::npos);
}

TEST(ModelFile, FailedWriteLeavesNoFile) {
  const InverseDynamicsModel m = small_model("gip", 20, 49, 5);
  EXPECT_NE(error_of([&] { save_model(m, "/nonexistent-dir/x.gipdyn"); }).find("does not exist"), std::string::npos);
  const fs::path target = temp_dir() / "partial.csv";
  EXPECT_THROW(write_file_atomically(target.string(), [](std::ostream& out) {
                 out << "half";
                 throw Error("simulated failure");
               }),
               Error);
  EXPECT_FALSE(fs::exists(target));
  for (const auto& entry : fs::directory_iterator(temp_dir()))
    EXPECT_EQ(entry.path().filename().string().find(".partial.csv.tmp"), std::string::npos);
}

// JSON cannot hold NaN: a fit report's missing numbers travel as nulls, and a
// non-finite parameter is refused before anything is written, naming where it
// is, instead of a file that saves and then never loads.
TEST(ModelFile, ReportsKeepTheirMissingNumbersAndNonFiniteParametersAreNotWritten) {
  const InverseDynamicsModel m = small_model("gip", 20, 50, 5);
  ModelContainer c = model_to_container(m);
  nlohmann::json& report = c.header["joint_models"][0]["training"];
  report["grad_norm"] = nullptr;  // a fit whose every evaluation failed has no gradient
  report["restart_nlls"] = {-12.5, nullptr};
  const InverseDynamicsModel with_gaps = model_from_container(c, "test container");
  EXPECT_TRUE(std::isnan(with_gaps.training_report()[0].grad_norm));
  const fs::path path = temp_dir() / "report_gaps.gipdyn";
  save_model(with_gaps, path.string());
  const InverseDynamicsModel loaded = load_model(path.string());
  EXPECT_TRUE(std::isnan(loaded.training_report()[0].grad_norm));
  ASSERT_EQ(loaded.training_report()[0].restart_nlls.size(), 2u);
  EXPECT_EQ(loaded.training_report()[0].restart_nlls[0], -12.5);
  EXPECT_TRUE(std::isnan(loaded.training_report()[0].restart_nlls[1]));
  EXPECT_EQ(loaded.training_report()[1].grad_norm, m.training_report()[1].grad_norm);

  ModelContainer broken = model_to_container(m);
  broken.header["joint_models"][1]["log_noise_variance"] = std::numeric_limits<double>::quiet_NaN();
  const fs::path target = temp_dir() / "nan_header.gipdyn";
  const std::string message = error_of([&] { write_container(broken, target.string()); });
  EXPECT_NE(message.find("header field 'joint_models/1/log_noise_variance'"), std::string::npos) << message;
  EXPECT_NE(message.find("nothing was written"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(target));
  EXPECT_NE(error_of([&] { pack_container(broken); }).find("joint_models/1/log_noise_variance"), std::string::npos);

  ModelContainer broken_array = model_to_container(m);
  broken_array.arrays.back().second(0, 0) = std::numeric_limits<double>::infinity();
  const std::string array_message = error_of([&] { write_container(broken_array, target.string()); });
  EXPECT_NE(array_message.find("array '" + broken_array.arrays.back().first + "'"), std::string::npos) << array_message;
  EXPECT_FALSE(fs::exists(target));
}

std::string file_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A CSV and its sidecar are replaced as a pair: when the new pair cannot be
// written, the old pair stays as it was, and no temporary is left behind.
TEST(AtomicFiles, AFailedPairLeavesTheOldPairAndNoTemporaries) {
  const fs::path dir = temp_dir() / "pair";
  fs::create_directories(dir);
  const fs::path csv = dir / "data.csv";
  write_csv_with_sidecar(csv.string(), {"a"}, Eigen::MatrixXd::Constant(2, 1, 1.0), {{"version", 1}});
  const std::string old_csv = file_text(csv), old_json = file_text(dir / "data.csv.json");
  Eigen::MatrixXd bad = Eigen::MatrixXd::Constant(3, 1, 2.0);
  bad(1, 0) = std::nan("");
  EXPECT_NE(error_of([&] { write_csv_with_sidecar(csv.string(), {"a"}, bad, {{"version", 2}}); })
                .find("data row 2, column 'a'"),
            std::string::npos);
  // A sidecar whose writer fails after the data's temporary was written.
  EXPECT_THROW(write_files_atomically({{csv.string(), [](std::ostream& o) { o << "a\n3\n"; }},
                                       {(dir / "data.csv.json").string(),
                                        [](std::ostream&) { throw Error("simulated failure"); }}}),
               Error);
  EXPECT_EQ(file_text(csv), old_csv);
  EXPECT_EQ(file_text(dir / "data.csv.json"), old_json);
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << entry.path();
}

// A killed run leaves ".NAME.tmp.PID"; the next write removes it, unless that process still runs.
TEST(AtomicFiles, TemporariesOfDeadProcessesAreRemoved) {
  const fs::path dir = temp_dir() / "stale";
  fs::create_directories(dir);
  const fs::path dead = dir / ".out.csv.tmp.2147483000", alive = dir / ".out.csv.tmp.1";
  std::ofstream(dead) << "half";
  std::ofstream(alive) << "in progress";
  write_csv((dir / "out.csv").string(), {"a"}, Eigen::MatrixXd::Ones(1, 1));
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(alive));  // pid 1 is running: its write may still finish
  EXPECT_EQ(file_text(dir / "out.csv"), "a\n1\n");
}

// A log exported by another tool, read with LogColumns, is the same dataset as the log under gipdyn's names.
TEST(LogColumns, ALogUnderOtherNamesReadsAsTheSameLogUnderGipdynsNames) {
  const JointTypes rr = JointTypes::parse("RR");
  const std::string values = "0.0,1,2,3,4,5,6,7,8\n0.1,1.5,2.5,3.5,4.5,5.5,6.5,7.5,8.5\n";
  const std::string ours = write_text_file("ours.csv", "t,q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n" + values);
  // ROS joint_states: joints counted from 0, in another column order; numbered from 1 with a suffix.
  const std::string ros = write_text_file(
      "ros.csv", "t,position_0,position_1,velocity_0,velocity_1,acc_0,acc_1,effort_0,effort_1\n" + values);
  const std::string suffixed = write_text_file("suffixed.csv", "t,j1_pos,j2_pos,qd1,qd2,qdd1,qdd2,tau1,tau2\n" + values);
  const Dataset expected = read_dataset(ours, rr, true);
  const LogColumns ros_names = parse_log_columns("q=position_{i0},qd=velocity_{i0},qdd=acc_{i0},tau=effort_{i0}");
  const Dataset from_ros = read_dataset(ros, rr, true, "", ros_names);
  EXPECT_EQ(from_ros.X, expected.X);
  EXPECT_EQ(from_ros.tau, expected.tau);
  const Dataset from_suffixed = read_dataset(suffixed, rr, true, "", parse_log_columns("q=j{i}_pos"));
  EXPECT_EQ(from_suffixed.X, expected.X);
  // The same patterns from a JSON file.
  const std::string json = write_text_file(
      "columns.json", R"({"q": "position_{i0}", "qd": "velocity_{i0}", "qdd": "acc_{i0}", "tau": "effort_{i0}"})");
  EXPECT_EQ(read_dataset(ros, rr, true, "", parse_log_columns(json)).X, expected.X);
  EXPECT_EQ(ros_names.log_name("tau", 2), "effort_1");
  EXPECT_TRUE(parse_log_columns("").is_default());
  EXPECT_FALSE(ros_names.is_default());
}

TEST(LogColumns, PatternsThatCannotBeRightAreRefusedByName) {
  const auto contains = [](const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
  };
  EXPECT_TRUE(contains(error_of([] { parse_log_columns("q=position"); }),
                       "LogColumns::q ('position') must hold exactly one {i}"));
  EXPECT_TRUE(contains(error_of([] { parse_log_columns("q={i}_{i0}"); }), "exactly one"));
  EXPECT_TRUE(contains(error_of([] { parse_log_columns("q=p{i},tau=p{i}"); }),
                       "LogColumns::q and LogColumns::tau are both ('p{i}')"));
  EXPECT_TRUE(contains(error_of([] { parse_log_columns("torque=effort_{i}"); }), "unknown quantity 'torque'"));
  EXPECT_TRUE(contains(error_of([] { parse_log_columns("q=a{i},q=b{i}"); }), "name q twice"));
  EXPECT_TRUE(contains(error_of([] { parse_log_columns("q:position_{i0}"); }), "neither"));
  EXPECT_TRUE(contains(error_of([] { parse_log_columns(write_text_file("bad.json", "[1]")); }), "not a JSON object"));
  const JointTypes rr = JointTypes::parse("RR");
  const std::string header_and_row = ",qd1,qd2,qdd1,qdd2,tau1,tau2\n1,2,3,4,5,6,7,8,9\n";
  // Two columns under one name: both p1 and p01 would be q1.
  const std::string both = write_text_file("both.csv", "p1,p2,p01" + header_and_row);
  EXPECT_TRUE(contains(error_of([&] { read_dataset(both, rr, true, "", parse_log_columns("q=p{i}")); }),
                       "columns 'p1' and 'p01' would both be q1"));
  // gipdyn's own name of a renamed quantity is not read as it.
  const std::string plain = write_text_file("plain.csv", "q1,q2,x" + header_and_row);
  EXPECT_TRUE(contains(error_of([&] { read_dataset(plain, rr, true, "", parse_log_columns("q=pos{i}")); }),
                       "has a column 'q1', gipdyn's name of a joint's q, but LogColumns::q says the log calls them pos{i}"));
  // A missing column is named as the log would call it.
  const std::string no_tau = write_text_file("no_tau.csv", "q1,q2,qd1,qd2,qdd1,qdd2,e1,e2\n1,2,3,4,5,6,7,8\n");
  EXPECT_TRUE(contains(error_of([&] { read_dataset(no_tau, rr, true, "", parse_log_columns("tau=effort_{i}")); }),
                       "has no column 'effort_1' (tau1 under the log's column names, LogColumns)"));
}

TEST(Dataset, ReadsColumnsByNameInAnyOrderAndNamesEachProblem) {
  const fs::path dir = temp_dir();
  const auto write = write_text_file;
  const JointTypes rr = JointTypes::parse("RR");
  const std::string ok = write("ok.csv",
                              "time,tau2,q1,q2,qd1,qd2,qdd1,qdd2,tau1,note\n"
                              "0.0,5,1,2,3,4,5,6,7,abc\n"
                              "0.1,6,1.5,2.5,3.5,4.5,5.5,6.5,7.5,def\n");
  const Dataset d = read_dataset(ok, rr, true);
  EXPECT_EQ(d.rows(), 2);
  EXPECT_DOUBLE_EQ(d.X(1, 0), 1.5);
  EXPECT_DOUBLE_EQ(d.tau(0, 0), 7);
  EXPECT_DOUBLE_EQ(d.tau(0, 1), 5);
  EXPECT_EQ(d.tau_true.size(), 0);

  EXPECT_NE(error_of([&] { read_dataset(write("m.csv", "q1,q2,qd1,qd2,qdd1,qdd2\n1,2,3,4,5,6\n"), rr, true); })
                .find("no column 'tau1' (its columns: q1, q2, qd1, qd2, qdd1, qdd2); add or rename it"),
            std::string::npos);
  // A log with its own spelling of the names: the column that looks like the wanted one is named.
  EXPECT_NE(error_of([&] {
              read_dataset(write("u.csv", "Q_1,Q_2,qd1,qd2,qdd1,qdd2,tau1,tau2\n1,2,3,4,5,6,7,8\n"), rr, true);
            }).find("no column 'q1' (its column 'Q_1' looks like it: rename it)"),
            std::string::npos);
  // Other common spellings of the derivatives and torques, and joints counted from 0.
  const auto error_reading = [&](const char* name, const std::string& header) {
    return error_of([&] { read_dataset(write(name, header + "\n1,2,3,4,5,6,7,8\n"), rr, true); });
  };
  EXPECT_NE(error_reading("d.csv", "q1,q2,dq_1,dq_2,ddq1,ddq2,tau1,tau2")
                .find("no column 'qd1' (its column 'dq_1' looks like it: rename it)"),
            std::string::npos);
  EXPECT_NE(error_reading("a.csv", "q1,q2,qd1,qd2,qddot1,qddot2,tau1,tau2")
                .find("no column 'qdd1' (its column 'qddot1' looks like it"),
            std::string::npos);
  EXPECT_NE(error_reading("f.csv", "q1,q2,qd1,qd2,qdd1,qdd2,effort1,effort2")
                .find("no column 'tau1' (its column 'effort1' looks like it"),
            std::string::npos);
  EXPECT_NE(error_reading("z.csv", "q0,q1,qd0,qd1,qdd0,qdd1,tau0,tau1")
                .find("z.csv' has a column 'q0': its joints are counted from 0, gipdyn's from 1 (q1 is the first "
                      "joint); rename the columns q0..q(n-1) to q1..qn, and qd, qdd and tau likewise"),
            std::string::npos);
  // rostopic echo -p: "field."-prefixed names, joints counted from 0.
  EXPECT_NE(error_reading("ros.csv", "field.position0,field.position1,field.velocity0,field.velocity1,qdd1,qdd2,"
                                     "field.effort0,field.effort1")
                .find("has a column 'field.position0': its joints are counted from 0"),
            std::string::npos);
  // A name that only shares its letters is not offered: qd1 is not tau1.
  EXPECT_EQ(error_reading("o.csv", "q1,q2,qd1,qd2,qdd1,qdd2,x1,x2").find("looks like it"), std::string::npos);
  EXPECT_NE(error_of([&] {
              read_dataset(write("t.csv", "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n1,2,3,x,5,6,7,8\n"), rr, true);
            }).find("line 2, column 'qd2': 'x' is not a number"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              read_dataset(write("n.csv", "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n1,2,3,nan,5,6,7,8\n"), rr, true);
            }).find("NaN"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              read_dataset(write("i.csv", "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n1,2,3,inf,5,6,7,8\n"), rr, true);
            }).find("NaN or Inf"),
            std::string::npos);
  EXPECT_NE(error_of([&] { read_dataset(write("e.csv", "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n"), rr, true); })
                .find("no data rows"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              read_dataset(write("s.csv", "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n1,2,3,4,5,6,7,8\n1,2,3\n"), rr, true);
            }).find("truncated"),
            std::string::npos);
  const std::string three = write("3.csv", "q1,q2,q3,qd1,qd2,qd3,qdd1,qdd2,qdd3,tau1,tau2,tau3\n1,2,3,4,5,6,7,8,9,1,2,3\n");
  EXPECT_NE(error_of([&] { read_dataset(three, rr, true); }).find("pass a joint string of length 3"),
            std::string::npos);
  // Joint types that come with a model: the file is what must change.
  const std::string model_says = error_of([&] { read_dataset(three, rr, true, "the model 'm.gipdyn'"); });
  EXPECT_NE(model_says.find("but the model 'm.gipdyn' is for 2 joints (RR); give it a file of the same robot: joint "
                            "columns q1..q2"),
            std::string::npos)
      << model_says;
  EXPECT_NE(error_of([&] { read_dataset((dir / "absent.csv").string(), rr, true); }).find("cannot open"),
            std::string::npos);
}

TEST(Dataset, ASidecarRecordsTheLogsJointTypes) {
  const auto write = write_text_file;
  const std::string log = write("side.csv", "q1,qd1,qdd1,tau1\n1,2,3,4\n");
  std::filesystem::remove(log + ".json");
  EXPECT_FALSE(sidecar_joint_types(log));
  EXPECT_FALSE(sidecar_generator(log));
  write("side.csv.json", "{\"joints\": 2, \"generator\": \"gipdyn preprocess\"}");  // a count, not types
  EXPECT_FALSE(sidecar_joint_types(log));
  EXPECT_EQ(sidecar_generator(log).value_or(""), "gipdyn preprocess");
  write("side.csv.json", "{\"joints\": \"RRPR\"}");
  ASSERT_TRUE(sidecar_joint_types(log));
  EXPECT_EQ(sidecar_joint_types(log)->str(), "RRPR");
  write("side.csv.json", "{\"joints\": \"RXR\"}");
  EXPECT_NE(error_of([&] { sidecar_joint_types(log); }).find("side.csv.json' of"), std::string::npos);
  write("side.csv.json", "{\"joints\": ");
  EXPECT_NE(error_of([&] { sidecar_joint_types(log); }).find("is not valid JSON"), std::string::npos);
  EXPECT_FALSE(sidecar_generator(log));  // a hint: a broken sidecar is sidecar_joint_types' to report
  std::filesystem::remove(log + ".json");
}

// The same numbers saved by a spreadsheet (byte-order mark, CRLF, tabs or
// semicolons) or by numpy.savetxt (a "# " header, spaces) read alike.
TEST(Dataset, ReadsLogsSavedByOtherToolsAlike) {
  const auto write = write_text_file;
  const JointTypes rr = JointTypes::parse("RR");
  const auto error_reading = [&](const std::string& name, const std::string& text) {
    return error_of([&] { read_dataset(write(name, text), rr, true); });
  };
  const Dataset plain = read_dataset(
      write("plain.csv", "q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n1,2,3,4,5,6,7,8\n-1.5,2e-3,3,4,5,6,7,8.25\n"), rr, true);
  const std::vector<std::pair<std::string, std::string>> variants = {
      {"bom.csv", "\xEF\xBB\xBFq1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\r\n1,2,3,4,5,6,7,8\r\n-1.5,2e-3,3,4,5,6,7,8.25\r\n"},
      {"tabs.tsv", "q1\tq2\tqd1\tqd2\tqdd1\tqdd2\ttau1\ttau2\n1\t2\t3\t4\t5\t6\t7\t8\n-1.5\t2e-3\t3\t4\t5\t6\t7\t8.25\n"},
      {"semi.csv", "q1;q2;qd1;qd2;qdd1;qdd2;tau1;tau2\n1;2;3;4;5;6;7;8\n-1.5;2e-3;3;4;5;6;7;8.25\n"},
      {"savetxt.txt",
       "# q1 q2 qd1 qd2 qdd1 qdd2 tau1 tau2\n1.0e+00  2 3 4 5 6 7 8\n# a comment\n -1.5 2e-3 3 4 5 6 7 8.25 \n"},
      {"rostopic.csv",  // header as a '%' comment over rows that hold a string
       "%time,frame,q1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n1000,base,1,2,3,4,5,6,7,8\n"
       "1001,base,-1.5,2e-3,3,4,5,6,7,8.25\n"},
      {"preamble.csv",
       "# logged by a controller\n% robot: two links\n\nq1,q2,qd1,qd2,qdd1,qdd2,tau1,tau2\n1,2,3,4,5,6,7,8\n"
       "-1.5,2e-3,3,4,5,6,7,8.25\n"}};
  for (const auto& [name, text] : variants) {
    const Dataset d = read_dataset(write(name, text), rr, true);
    EXPECT_EQ(d.X, plain.X) << name;
    EXPECT_EQ(d.tau, plain.tau) << name;
  }
  EXPECT_NE(error_reading("bare.csv", "1,2,3,4,5,6,7,8\n1,2,3,4,5,6,7,8\n")
                .find("'" + (temp_dir() / "bare.csv").string() + "' has no header row: its first line holds numbers ('1', ...); "
                      "add a first line naming the columns"),
            std::string::npos);
  // Line numbers count the preamble: the bad cell is on line 4 of the file.
  EXPECT_NE(error_reading("late.txt", "# note\n# q1 q2 qd1 qd2 qdd1 qdd2 tau1 tau2\n1 2 3 4 5 6 7 8\n1 2 x 4 5 6 7 8\n")
                .find("line 4, column 'qd1': 'x' is not a number"),
            std::string::npos);
  EXPECT_NE(error_reading("comma.csv", "q1;q2;qd1;qd2;qdd1;qdd2;tau1;tau2\n1,5;2;3;4;5;6;7;8\n")
                .find("column 'q1': '1,5' is not a number (a decimal comma? gipdyn reads '.' as the decimal mark"),
            std::string::npos);
}

TEST(Metrics, NmseUsesPopulationVariance) {
  Eigen::MatrixXd t(4, 1), p(4, 1);
  t << 1, 2, 3, 4;
  p << 1, 2, 3, 5;
  const Accuracy a = compute_accuracy(t, p);
  EXPECT_DOUBLE_EQ(a.mse(0), 0.25);
  EXPECT_DOUBLE_EQ(a.nmse(0), 0.25 / 1.25);
  EXPECT_DOUBLE_EQ(a.gmse, 0.25);
}

TEST(Metrics, AConstantTargetHasNoNmseEvenWhereItsMeanRounds) {
  // 0.1 summed 37 times is not 3.7 in double, so a variance from the rounded mean
  // is about 1e-33, and the nMSE of a tiny error would read 1e27 "worse than the mean".
  Eigen::MatrixXd t = Eigen::MatrixXd::Constant(37, 2, 0.1), p = t;
  t.col(1).setLinSpaced(37, 0.0, 1.0);
  p.array() += 1e-6;
  const Accuracy a = compute_accuracy(t, p);
  EXPECT_TRUE(std::isinf(a.nmse(0)));
  EXPECT_EQ(column_variance(t)(0), 0.0);
  EXPECT_GT(column_variance(t)(1), 0.0);
  EXPECT_NEAR(a.mse(0), 1e-12, 1e-20);
}

}  // namespace
}  // namespace gipdyn

TEST(Progress, DescribesOptimiserStepsJointEndsAndWholeFits) {
  using gipdyn::describe;
  using gipdyn::ProgressEvent;
  ProgressEvent step;
  step.estimator = "gip";
  step.joint = 1;
  step.iteration = 40;
  step.objective = -1234.5;
  step.grad_norm = 0.012;
  step.seconds = 3.1;
  EXPECT_EQ(describe(step), "gip joint 2 iteration 40: objective -1234.5 |grad| 0.012 (3.1 s)");
  ProgressEvent joint_end = step;
  joint_end.finished = true;
  joint_end.message = "converged";
  EXPECT_EQ(describe(joint_end), "gip joint 2 done after 40 iterations (3.1 s): objective -1234.5, converged");
  ProgressEvent fit_end;
  fit_end.estimator = "gip";
  fit_end.finished = true;
  fit_end.seconds = 81.8;
  fit_end.message = "fit not converged";
  EXPECT_EQ(describe(fit_end), "gip fit not converged (81.8 s)");
  ProgressEvent epoch;
  epoch.estimator = "nn";
  epoch.iteration = 7;
  epoch.objective = 0.25;
  epoch.seconds = 1.0;
  EXPECT_EQ(describe(epoch), "nn iteration 7: objective 0.25 (1.0 s)");
}

// Every task runs once, on as many threads as asked; a task's exception
// reaches the caller after the threads stop, and later tasks do not start.
TEST(ParallelTasks, RunEachTaskOnceAndRethrowTheFirstFailure) {
  std::vector<int> runs(7, 0);
  std::mutex mu;
  std::set<std::thread::id> ids;
  gipdyn::run_tasks(7, 3, [&](int t) {
    const std::lock_guard<std::mutex> lock(mu);
    ++runs[static_cast<size_t>(t)];
    ids.insert(std::this_thread::get_id());
  });
  EXPECT_EQ(runs, std::vector<int>(7, 1));
  EXPECT_LE(ids.size(), 3u);
  std::atomic<int> started{0};
  EXPECT_EQ(gipdyn::test::error_of([&] {
              gipdyn::run_tasks(50, 1, [&](int t) {
                ++started;
                if (t == 2) throw gipdyn::Error("task 2 failed");
              });
            }),
            "task 2 failed");
  EXPECT_EQ(started.load(), 3);
  EXPECT_EQ(gipdyn::worker_threads(4, 2), 2);
  EXPECT_EQ(gipdyn::worker_threads(3, 5), 3);
  EXPECT_EQ(gipdyn::worker_threads(0, 0), 1);
  // No more threads than memory holds tasks, and at least one.
  const double available = static_cast<double>(gipdyn::available_memory_bytes());
  EXPECT_EQ(gipdyn::worker_threads(8, 8, available / 2.5), 2);
  EXPECT_EQ(gipdyn::worker_threads(8, 8, 10.0 * available), 1);
}

// Ranges cover their items once, in order; a single range runs on the
// caller's thread, several each once with their own bounds.
TEST(ParallelTasks, RangesCoverTheItemsOnceAndEachRunsWithItsBounds) {
  using Bounds = std::vector<std::ptrdiff_t>;
  EXPECT_EQ(gipdyn::equal_ranges(10, 4), (Bounds{0, 4, 8, 10}));
  EXPECT_EQ(gipdyn::equal_ranges(8, 4), (Bounds{0, 4, 8}));
  EXPECT_EQ(gipdyn::equal_ranges(3, 4), (Bounds{0, 3}));
  EXPECT_EQ(gipdyn::equal_ranges(0, 4), (Bounds{0, 0}));
  const Bounds bounds{0, 3, 4, 9, 20};
  std::vector<int> covered(20, 0);
  std::mutex mu;
  gipdyn::run_range_tasks(bounds, [&](int t, std::ptrdiff_t begin, std::ptrdiff_t end) {
    const std::lock_guard<std::mutex> lock(mu);
    EXPECT_EQ(begin, bounds[static_cast<size_t>(t)]);
    EXPECT_EQ(end, bounds[static_cast<size_t>(t) + 1]);
    for (std::ptrdiff_t i = begin; i < end; ++i) ++covered[static_cast<size_t>(i)];
  });
  EXPECT_EQ(covered, std::vector<int>(20, 1));
  std::thread::id runner;
  gipdyn::run_range_tasks(Bounds{0, 5}, [&](int, std::ptrdiff_t, std::ptrdiff_t) { runner = std::this_thread::get_id(); });
  EXPECT_EQ(runner, std::this_thread::get_id());
}

TEST(Memory, RefusesWhatTheMachineCannotHoldWithTheEstimate) {
  EXPECT_EQ(gipdyn::format_bytes(512), "512 B");
  EXPECT_EQ(gipdyn::format_bytes(1.5 * 1024 * 1024 * 1024), "1.5 GiB");
  EXPECT_GT(gipdyn::available_memory_bytes(), 1u << 20);
  gipdyn::require_memory(1024, "a small thing", "nothing to do");
  const std::string message = gipdyn::test::error_of([] { gipdyn::require_memory(1e30, "a huge thing", "ask less"); });
  EXPECT_NE(message.find("a huge thing needs about"), std::string::npos) << message;
  EXPECT_NE(message.find("available; ask less"), std::string::npos) << message;
}

TEST(TrainingData, FindsRevoluteJointsWhosePositionsSpanMoreThanTwoTurns) {
  const gipdyn::JointTypes rpr = gipdyn::JointTypes::parse("RPR");
  Eigen::MatrixXd X = gipdyn::test::random_inputs(rpr, 40, 3);
  EXPECT_TRUE(gipdyn::revolute_joints_spanning_turns(X, rpr).empty());
  X.col(0) *= 180.0 / 3.14159265358979323846;  // joint 1 in degrees
  X.col(1) *= 100.0;                              // a prismatic joint may move far: not a turn
  X(7, 2) = X.col(2).minCoeff() + 12.5;           // just under two turns (12.566 rad)
  EXPECT_EQ(gipdyn::revolute_joints_spanning_turns(X, rpr), (std::vector<int>{0}));
  X(7, 2) += 0.1;
  EXPECT_EQ(gipdyn::revolute_joints_spanning_turns(X, rpr), (std::vector<int>{0, 2}));
}

TEST(TrainingData, FindsConstantColumnsAndRowsSharedWithTraining) {
  Eigen::MatrixXd X = gipdyn::test::random_inputs(gipdyn::JointTypes::parse("RR"), 30, 7);
  X.col(3).setConstant(0.25);
  X.col(5).setConstant(1e6);
  X(4, 5) += 1e-9;  // nearly constant: a change at rounding level of the column's size
  EXPECT_EQ(gipdyn::constant_columns(X), (std::vector<Eigen::Index>{3, 5}));
  Eigen::MatrixXd test = gipdyn::test::random_inputs(gipdyn::JointTypes::parse("RR"), 10, 8);
  EXPECT_EQ(gipdyn::count_shared_rows(X, test), 0);
  test.row(2) = X.row(17);
  test.row(6) = X.row(0);
  EXPECT_EQ(gipdyn::count_shared_rows(X, test), 2);
  test(6, 1) = std::nextafter(test(6, 1), 10.0);  // one bit away is another state
  EXPECT_EQ(gipdyn::count_shared_rows(X, test), 1);
}
