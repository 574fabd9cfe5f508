// Single-query latency of a trained model (any estimator: GP kernels, lip, fe,
// nn) on the rows of a log: what one call of the control-loop path (the
// estimator's QueryWorkspace::predict, which the C API's gipdyn_predict wraps)
// costs on the states a robot actually visits.
//
//   build/bench/bench_prediction_latency MODEL DATA [ROWS]
//
// DATA is a log in the CSV layout of README.md, "Data files", with the
// model's joints; the first ROWS rows (default 3000) are queried three times
// each, in order, and p50, p99 and the maximum are printed. The same for one
// step of the contact detector (sensing/contact_detection.hpp, ContactStream,
// what the C API's gipdyn_contact_detector_step wraps) by the residual method
// and, for models with physics, the momentum method. The process keeps its
// default floating-point mode, as a caller's control loop would.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/estimators/estimator_file.hpp"
#include "gipdyn/estimators/physics.hpp"
#include "gipdyn/model/inverse_dynamics_model.hpp"
#include "gipdyn/sensing/contact_detection.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_prediction_latency MODEL DATA [ROWS]   (ROWS default 3000)\n");
    return 2;
  }
  try {
    const std::unique_ptr<gipdyn::Estimator> model = gipdyn::load_estimator(argv[1]);
    const gipdyn::Dataset data =
        gipdyn::read_dataset(argv[2], model->joints(), true, std::string("the model '") + argv[1] + "'");
    const Eigen::Index rows = std::min<Eigen::Index>(data.rows(), argc > 3 ? std::atol(argv[3]) : 3000);
    if (rows < 1) throw gipdyn::Error("ROWS must be at least 1");
    const std::unique_ptr<gipdyn::QueryWorkspace> workspace = model->make_query_workspace();
    const int joints = model->joints().size();
    Eigen::VectorXd x(data.X.cols()), tau(joints);
    std::vector<double> micros;
    micros.reserve(static_cast<size_t>(3 * rows));
    // Three passes over the rows, each call of `one(row)` timed; the sorted times.
    const auto timed = [&](const auto& one) {
      micros.clear();
      for (int pass = 0; pass < 3; ++pass)
        for (Eigen::Index i = 0; i < rows; ++i) {
          x = data.X.row(i).transpose();
          const auto start = std::chrono::steady_clock::now();
          one(i);
          micros.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count());
        }
      std::sort(micros.begin(), micros.end());
      char line[128];
      std::snprintf(line, sizeof line, "%zu calls, p50 %.1f us, p99 %.1f us, max %.1f us", micros.size(),
                    micros[micros.size() / 2], micros[micros.size() * 99 / 100], micros.back());
      return std::string(line);
    };
    const gipdyn::InverseDynamicsModel* gp = model->gp_model();
    const std::string name = gp ? gp->kernel_name() : model->name();
    const std::string rows_note =
        gp ? ", " + std::to_string(gp->num_training_samples()) + " training rows" : "";
    std::printf("%s, %d joints%s: queries: %s\n", name.c_str(), joints, rows_note.c_str(),
                timed([&](Eigen::Index) { workspace->predict(x.data(), tau.data()); }).c_str());
    // The detector's step; its threshold's sigma does not change its cost.
    Eigen::VectorXd ext(joints), margin(joints);
    Eigen::VectorXi contact(joints);
    const Eigen::MatrixXd measured = data.tau.transpose();  // column i: row i's torques, contiguous
    for (const gipdyn::ContactMethod method : {gipdyn::ContactMethod::Residual, gipdyn::ContactMethod::Momentum}) {
      if (method == gipdyn::ContactMethod::Momentum && !model->gives_rigid_body_terms()) continue;
      gipdyn::ContactOptions options;
      options.method = method;
      options.sample_time = 0.001;
      gipdyn::ContactStream stream(*model, options, Eigen::VectorXd::Ones(joints));
      const Eigen::Index n = joints;
      const std::string line = timed([&](Eigen::Index i) {
        stream.step(x.data(), x.data() + n, x.data() + 2 * n, measured.col(i).data(), ext.data(), contact.data(),
                    margin.data());
      });
      std::printf("%s, %d joints: contact detector steps (%s): %s\n", name.c_str(), joints,
                  gipdyn::to_string(method).c_str(), line.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_prediction_latency: %s\n", e.what());
    return 1;
  }
  return 0;
}
