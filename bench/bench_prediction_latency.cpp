// Single-query latency of a trained model (any estimator: GP kernels, lip, fe,
// nn) on the rows of a log: what one call of the control-loop path (the
// estimator's QueryWorkspace::predict, which the C API's gipdyn_predict wraps)
// costs on the states a robot actually visits.
//
//   build/bench/bench_prediction_latency MODEL DATA [ROWS]
//
// DATA is a log in the CSV layout of README.md, "Data files", with the
// model's joints; the first ROWS rows (default 3000) are queried three times
// each, in order, and p50, p99 and the maximum are printed. The process keeps
// its default floating-point mode, as a caller's control loop would.
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
#include "gipdyn/model/inverse_dynamics_model.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_prediction_latency MODEL DATA [ROWS]   (ROWS default 3000)\n");
    return 2;
  }
  try {
    const std::unique_ptr<gipdyn::Estimator> model = gipdyn::load_estimator(argv[1]);
    const gipdyn::Dataset data =
        gipdyn::read_dataset(argv[2], model->joints(), false, std::string("the model '") + argv[1] + "'");
    const Eigen::Index rows = std::min<Eigen::Index>(data.rows(), argc > 3 ? std::atol(argv[3]) : 3000);
    if (rows < 1) throw gipdyn::Error("ROWS must be at least 1");
    const std::unique_ptr<gipdyn::QueryWorkspace> workspace = model->make_query_workspace();
    const int joints = model->joints().size();
    Eigen::VectorXd x(data.X.cols()), tau(joints);
    std::vector<double> micros;
    micros.reserve(static_cast<size_t>(3 * rows));
    for (int pass = 0; pass < 3; ++pass)
      for (Eigen::Index i = 0; i < rows; ++i) {
        x = data.X.row(i).transpose();
        const auto start = std::chrono::steady_clock::now();
        workspace->predict(x.data(), tau.data());
        micros.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count());
      }
    std::sort(micros.begin(), micros.end());
    const gipdyn::InverseDynamicsModel* gp = model->gp_model();
    const std::string name = gp ? gp->kernel_name() : model->name();
    const std::string rows_note =
        gp ? ", " + std::to_string(gp->num_training_samples()) + " training rows" : "";
    std::printf("%s, %d joints%s: %zu queries, p50 %.1f us, p99 %.1f us, max %.1f us\n", name.c_str(), joints,
                rows_note.c_str(), micros.size(), micros[micros.size() / 2], micros[micros.size() * 99 / 100], micros.back());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_prediction_latency: %s\n", e.what());
    return 1;
  }
  return 0;
}
