// The C API against the C++ API it wraps: the same torques, gravity and
// inertia, and a status with a message (never a crash) for every misuse.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/gp_estimator.hpp"
#include "gipdyn/estimators/neural_network.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/gipdyn.h"
#include "gipdyn/version.hpp"
#include "gipdyn/model/model_file.hpp"
#include "gipdyn/model/training.hpp"
#include "gipdyn/robot/robot_loader.hpp"
#include "gipdyn/sim/simulate.hpp"
#include "test_util.hpp"

namespace gipdyn {
namespace {

namespace fs = std::filesystem;

fs::path temp_file(const std::string& name) {
  return fs::temp_directory_path() / ("gipdyn_c_api_" + std::to_string(::getpid()) + "_" + name);
}

struct Trained {
  InverseDynamicsModel model;
  std::string path;
};

Trained train_and_save(const std::string& kernel) {
  const JointTypes joints = JointTypes::parse("RR");
  const Eigen::MatrixXd X = test::random_inputs(joints, 120, 71);
  TrainOptions o;
  o.kernel = kernel;
  o.search.optimizer.max_iterations = 40;
  TrainResult r = train_model(X, test::two_link_torques(X) + 0.01 * test::random_matrix(120, 2, -1.0, 1.0, 901), joints, o);
  EXPECT_TRUE(r.report.ok()) << r.report.message;
  const std::string path = temp_file(kernel + ".gipdyn").string();
  save_model(r.model, path);
  return {std::move(r.model), path};
}

struct CModel {
  gipdyn_model* model = nullptr;
  gipdyn_workspace* ws = nullptr;
  explicit CModel(const std::string& path) {
    EXPECT_EQ(gipdyn_model_load(path.c_str(), &model), GIPDYN_OK) << gipdyn_last_error();
    if (model) {
      EXPECT_EQ(gipdyn_workspace_create(model, &ws), GIPDYN_OK) << gipdyn_last_error();
    }
  }
  ~CModel() {
    gipdyn_workspace_free(ws);
    gipdyn_model_free(model);
  }
};

TEST(CApi, TorqueGravityAndInertiaMatchTheCppApi) {
  const Trained t = train_and_save("gip");
  CModel c(t.path);
  ASSERT_NE(c.ws, nullptr);
  EXPECT_EQ(gipdyn_model_num_joints(c.model), 2);
  EXPECT_EQ(gipdyn_model_has_physics(c.model), 1);
  const GpEstimator estimator(t.model);
  const Eigen::MatrixXd X = test::random_inputs(JointTypes::parse("RR"), 5, 72);
  const Eigen::MatrixXd expected = t.model.predict(X);
  const Eigen::MatrixXd G = gravity(estimator, X.leftCols(2));
  const std::vector<Eigen::MatrixXd> Ms = inertia(estimator, X.leftCols(2));
  const Eigen::MatrixXd QDD = forward_dynamics(estimator, X.leftCols(2), X.middleCols(2, 2), expected);
  PredictionWorkspace cpp(t.model);
  for (int r = 0; r < X.rows(); ++r) {
    const Eigen::VectorXd x = X.row(r).transpose();
    double tau[2], g[2], M[4], cpp_tau[2], qdd[2];
    ASSERT_EQ(gipdyn_predict(c.ws, x.data(), x.data() + 2, x.data() + 4, 2, tau), GIPDYN_OK) << gipdyn_last_error();
    ASSERT_EQ(gipdyn_gravity(c.ws, x.data(), 2, g), GIPDYN_OK);
    ASSERT_EQ(gipdyn_inertia(c.ws, x.data(), 2, M), GIPDYN_OK);
    ASSERT_EQ(gipdyn_forward_dynamics(c.ws, x.data(), x.data() + 2, tau, 2, qdd), GIPDYN_OK) << gipdyn_last_error();
    EXPECT_STREQ(gipdyn_last_error(), "");
    cpp.predict(x.data(), cpp_tau);
    // The batch path sums k(x*, X) alpha in another order, and |alpha| amplifies
    // the last bits: agreement to rounding, on the scale of the torques.
    const double scale = 1.0 + expected.row(r).cwiseAbs().maxCoeff() + G.row(r).cwiseAbs().maxCoeff();
    // Plus the rounding of the predictions behind each: the torque at the state,
    // g at (q, 0, 0), M's columns at (q, 0, e_k) minus g.
    auto rounding = [&](int j, const Eigen::VectorXd& state) { return test::prediction_rounding(t.model, j, state); };
    Eigen::VectorXd at_rest = x;
    at_rest.tail(4).setZero();
    for (int j = 0; j < 2; ++j) {
      const double r_tau = rounding(j, x), r_g = rounding(j, at_rest);
      double r_m = 0.0;
      for (int k = 0; k < 2; ++k) {
        Eigen::VectorXd unit = at_rest;
        unit(4 + k) = 1.0;
        r_m = std::max(r_m, rounding(j, unit));
      }
      EXPECT_EQ(tau[j], cpp_tau[j]);  // same path, model read back bit for bit
      EXPECT_NEAR(tau[j], expected(r, j), 1e-6 * scale + r_tau);
      EXPECT_NEAR(g[j], G(r, j), 1e-6 * scale + r_g);
      for (int k = 0; k < 2; ++k) EXPECT_NEAR(M[j * 2 + k], Ms[static_cast<size_t>(r)](j, k), 1e-6 * scale + r_m + r_g);
      // The torques the model predicts for (q, qd, qdd) give back qdd (M^-1 amplifies rounding).
      EXPECT_NEAR(qdd[j], x(4 + j), 1e-3 * (1.0 + std::abs(x(4 + j))));
      EXPECT_NEAR(qdd[j], QDD(r, j), 1e-3 * (1.0 + std::abs(x(4 + j))));
    }
  }
  fs::remove(t.path);
}

TEST(CApi, MisuseGetsAStatusAndAMessage) {
  const Trained t = train_and_save("rbf");
  CModel c(t.path);
  ASSERT_NE(c.ws, nullptr);
  const double q[2] = {0.1, 0.2}, zero[2] = {0, 0}, nan_q[2] = {0.1, std::nan("")};
  double out[4];
  EXPECT_EQ(gipdyn_predict(nullptr, q, zero, zero, 2, out), GIPDYN_ERROR_NULL_ARGUMENT);
  EXPECT_EQ(gipdyn_predict(c.ws, q, nullptr, zero, 2, out), GIPDYN_ERROR_NULL_ARGUMENT);
  EXPECT_EQ(gipdyn_predict(c.ws, q, zero, zero, 2, nullptr), GIPDYN_ERROR_NULL_ARGUMENT);
  EXPECT_EQ(gipdyn_predict(c.ws, q, zero, zero, 6, out), GIPDYN_ERROR_SIZE);
  EXPECT_NE(std::string(gipdyn_last_error()).find("joint count"), std::string::npos) << gipdyn_last_error();
  EXPECT_EQ(gipdyn_predict(c.ws, nan_q, zero, zero, 2, out), GIPDYN_ERROR_NOT_FINITE);
  EXPECT_NE(std::string(gipdyn_last_error()).find("NaN"), std::string::npos);
  // An RBF model has no rigid-body structure.
  EXPECT_EQ(gipdyn_model_has_physics(c.model), 0);
  EXPECT_EQ(gipdyn_gravity(c.ws, q, 2, out), GIPDYN_ERROR_UNSUPPORTED);
  EXPECT_EQ(gipdyn_inertia(c.ws, q, 2, out), GIPDYN_ERROR_UNSUPPORTED);
  EXPECT_EQ(gipdyn_forward_dynamics(c.ws, q, zero, zero, 2, out), GIPDYN_ERROR_UNSUPPORTED);
  EXPECT_NE(std::string(gipdyn_last_error()).find("gip"), std::string::npos);
  // A good call clears the message.
  EXPECT_EQ(gipdyn_predict(c.ws, q, zero, zero, 2, out), GIPDYN_OK);
  EXPECT_STREQ(gipdyn_last_error(), "");

  EXPECT_EQ(gipdyn_model_num_joints(nullptr), -1);
  EXPECT_EQ(gipdyn_workspace_create(nullptr, nullptr), GIPDYN_ERROR_NULL_ARGUMENT);
  gipdyn_workspace* ws = reinterpret_cast<gipdyn_workspace*>(0x1);
  EXPECT_EQ(gipdyn_workspace_create(nullptr, &ws), GIPDYN_ERROR_NULL_ARGUMENT);
  EXPECT_EQ(ws, nullptr);  // outputs are NULL on failure, so freeing them is safe
  gipdyn_workspace_free(nullptr);
  gipdyn_model_free(nullptr);
  EXPECT_STREQ(gipdyn_status_string(GIPDYN_ERROR_SIZE), "wrong size");
  EXPECT_STREQ(gipdyn_version(), gipdyn::version());
  EXPECT_EQ(std::string(gipdyn_build_info()), gipdyn::build_summary());

  // Files: missing, truncated.
  gipdyn_model* m = nullptr;
  EXPECT_EQ(gipdyn_model_load(nullptr, &m), GIPDYN_ERROR_NULL_ARGUMENT);
  EXPECT_EQ(gipdyn_model_load("/nonexistent/arm.gipdyn", &m), GIPDYN_ERROR_FILE);
  EXPECT_EQ(m, nullptr);
  EXPECT_NE(std::string(gipdyn_last_error()).find("/nonexistent/arm.gipdyn"), std::string::npos) << gipdyn_last_error();
  const fs::path truncated = temp_file("truncated.gipdyn");
  {
    std::ifstream in(t.path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  EXPECT_EQ(gipdyn_model_load(truncated.c_str(), &m), GIPDYN_ERROR_FILE);
  EXPECT_EQ(m, nullptr);
  fs::remove(truncated);
  fs::remove(t.path);
}

// Every estimator's model file works through the C API, with the torques of
// the C++ API; gravity where the estimator gives it; and a flag that says
// whether its queries allocate.
TEST(CApi, EveryEstimatorPredictsAsTheCppApi) {
  SimulationOptions so;
  so.samples = 200;
  const SimulationResult sim = simulate(load_robot("scara"), so);
  const JointTypes joints = JointTypes::parse("RRPR");
  struct Expect {
    std::string name;
    bool physics, allocation_free;
  };
  std::vector<Expect> cases = {{"gip", true, true}, {"rbf", false, true}, {"fe", true, true}, {"lip", true, true}};
  if (neural_network_training_available()) cases.push_back({"nn", false, true});
  for (const Expect& c : cases) {
    EstimatorOptions o;
    o.name = c.name;
    o.robot_prior.robot = std::make_shared<const RobotModel>(load_robot("scara"));
    o.search.optimizer.max_iterations = 15;
    o.nn.epochs = 3;
    const bool lip = c.name == "lip";
    const Eigen::MatrixXd X = lip ? Eigen::MatrixXd(sim.X.topRows(60)) : sim.X;
    const Eigen::MatrixXd Y = lip ? Eigen::MatrixXd(sim.tau.topRows(60)) : sim.tau;
    FitResult f = fit_estimator(o, X, Y, joints);
    ASSERT_TRUE(f.report.ok()) << c.name << ": " << f.report.message;
    const fs::path path = temp_file(c.name + ".gipdyn");
    save_estimator(*f.estimator, path.string());
    CModel m(path.string());
    fs::remove(path);
    ASSERT_NE(m.ws, nullptr) << c.name;
    EXPECT_EQ(gipdyn_model_num_joints(m.model), 4);
    EXPECT_EQ(gipdyn_model_has_physics(m.model), c.physics ? 1 : 0) << c.name;
    EXPECT_EQ(gipdyn_model_allocation_free(m.model), c.allocation_free ? 1 : 0) << c.name;
    const Eigen::MatrixXd states = sim.X.bottomRows(5);
    const Eigen::MatrixXd expected = f.estimator->predict(states);
    for (Eigen::Index r = 0; r < states.rows(); ++r) {
      const Eigen::RowVectorXd x = states.row(r);
      double tau[4];
      ASSERT_EQ(gipdyn_predict(m.ws, x.data(), x.data() + 4, x.data() + 8, 4, tau), GIPDYN_OK) << gipdyn_last_error();
      for (int j = 0; j < 4; ++j)
        EXPECT_NEAR(tau[j], expected(r, j), 1e-9 * (1.0 + std::abs(expected(r, j)))) << c.name << " joint " << j + 1;
      if (!c.physics) continue;
      Eigen::MatrixXd at_rest = Eigen::MatrixXd::Zero(1, 12);
      at_rest.leftCols(4) = x.head(4);
      const Eigen::MatrixXd g_expected = f.estimator->predict(at_rest);
      double g[4];
      ASSERT_EQ(gipdyn_gravity(m.ws, x.data(), 4, g), GIPDYN_OK) << gipdyn_last_error();
      for (int j = 0; j < 4; ++j) EXPECT_NEAR(g[j], g_expected(0, j), 1e-9 * (1.0 + std::abs(g_expected(0, j))));
    }
  }
}

// The library reports the Eigen layout and instruction set it was compiled with;
// this file is compiled with the flags a consumer of the gipdyn target gets, so
// the two must agree, and both must be the 16-byte layout of Debian's libraries.
TEST(BuildInfo, SaysHowTheLibraryWasCompiledAndMatchesItsConsumers) {
  const BuildInfo info = build_info();
  EXPECT_EQ(info.eigen_static_align_bytes, EIGEN_MAX_STATIC_ALIGN_BYTES);
  EXPECT_EQ(info.eigen_heap_align_bytes, EIGEN_DEFAULT_ALIGN_BYTES);
  EXPECT_EQ(info.eigen_heap_align_bytes, 16);
  EXPECT_EQ(info.eigen_simd, Eigen::SimdInstructionSetsInUse());
#if defined(__x86_64__)
#if defined(__SSE4_2__)
  EXPECT_NE(info.instruction_set.find("SSE4.2"), std::string::npos) << info.instruction_set;
#else
  EXPECT_EQ(info.instruction_set, "x86-64 (SSE2)");
#endif
  EXPECT_EQ(info.instruction_set.find("AVX"), std::string::npos) << info.instruction_set;
  EXPECT_FALSE(running_cpu_features().empty());
#endif
  const std::string summary = build_summary();
  EXPECT_NE(summary.find("built for " + info.instruction_set + "; Eigen " + info.eigen_version), std::string::npos)
      << summary;
  EXPECT_NE(summary.find("16-byte alignment"), std::string::npos) << summary;
}

}  // namespace
}  // namespace gipdyn
