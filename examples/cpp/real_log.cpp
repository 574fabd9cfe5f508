// A real robot's log with the preset "real" (docs/results/real-robots.md): the rows
// before SPLIT_ROW train (a constant-step subsample of at most the preset's
// 1000 rows, or TRAIN_ROWS), the rows from SPLIT_ROW on test (other motions).
// Before training, a model-free check says whether the test rows follow the
// same function of the state as the training rows; then the per-joint test
// nMSE, beside that of plain GIP trained on the same rows unless SKIP_GIP is 1.
//   build/real_log CSV JOINTS SPLIT_ROW [TRAIN_ROWS] [MAX_ITER] [SKIP_GIP]
// TRAIN_ROWS 0: every row before SPLIT_ROW; MAX_ITER 0: the library's safety cap.
// The shared UR10 log with its reference split (train on data rows 1-6340):
//   build/real_log ../shared/data/ur10-pick-and-place/urPicknPlace.csv RRRRRR 6341
// (2.5 minutes on 2 cores; mean test nMSE 0.78 with the preset, 2.1 with plain GIP, whose
// polynomial runs away on joint 5: 8.3). CSV: columns q1..qn, qd1..qdn, qdd1..qddn and
// tau1..taun (docs/reference/log-format.md).
// Its Python twin is examples/python/ur10_real.py; `gipdyn train --preset real` does the same.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "gipdyn/data_consistency.hpp"
#include "gipdyn/error.hpp"
#include "gipdyn/estimators/fit_estimator.hpp"
#include "gipdyn/estimators/presets.hpp"
#include "gipdyn/io/dataset.hpp"
#include "gipdyn/metrics.hpp"
#include "gipdyn/training_data.hpp"

namespace {

// Fits on the training rows and prints the test nMSE per joint; false, with the reason on stderr, where the fit fails.
bool fit_and_test(const char* name, const gipdyn::EstimatorOptions& options, const gipdyn::Dataset& train,
                  const gipdyn::Dataset& test, const gipdyn::JointTypes& joints) {
  const gipdyn::FitResult fit = gipdyn::fit_estimator(options, train.X, train.tau, joints);
  if (!fit.report.ok()) {
    std::fprintf(stderr, "real_log: %s: %s\n", name, fit.report.message.c_str());
    return false;
  }
  const Eigen::VectorXd nmse = gipdyn::compute_accuracy(test.tau, fit.estimator->predict(test.X)).nmse;
  std::printf("  %-36s", name);
  for (Eigen::Index j = 0; j < nmse.size(); ++j) std::printf(" %7.3f", nmse(j));
  std::printf("   mean %.3f  (%.0f s)\n", nmse.mean(), fit.report.seconds);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s CSV JOINTS SPLIT_ROW [TRAIN_ROWS] [MAX_ITER] [SKIP_GIP]\n", argv[0]);
    return 2;
  }
  try {
    const gipdyn::JointTypes joints = gipdyn::JointTypes::parse(argv[2]);
    const gipdyn::Dataset log = gipdyn::read_dataset(argv[1], joints, /*require_tau=*/true);
    const long split = std::atol(argv[3]) - 1;  // the first test row, counted from 0
    if (split < 1 || split >= log.rows()) {
      std::fprintf(stderr, "real_log: SPLIT_ROW must lie between 2 and the log's %ld rows, got %s\n",
                   static_cast<long>(log.rows()), argv[3]);
      return 2;
    }
    gipdyn::EstimatorOptions preset = gipdyn::preset_options("real");
    const long train_rows = argc > 4 ? std::atol(argv[4]) : gipdyn::preset_max_training_rows("real");
    if (argc > 5 && std::atoi(argv[5]) != 0) preset.search.optimizer.max_iterations = std::atoi(argv[5]);
    const bool skip_gip = argc > 6 && std::atoi(argv[6]) != 0;
    if (train_rows < 0) {
      std::fprintf(stderr, "real_log: TRAIN_ROWS must be at least 0 (0: every row before SPLIT_ROW), got %ld\n",
                   train_rows);
      return 2;
    }

    std::vector<Eigen::Index> before_split, after_split;
    for (Eigen::Index r = 0; r < log.rows(); ++r) (r < split ? before_split : after_split).push_back(r);
    const gipdyn::Dataset before = log.subset(before_split), test = log.subset(after_split);
    const gipdyn::Dataset train = before.subset(gipdyn::constant_step_indices(before.rows(), train_rows));

    // Before training: at states both parts visit, do their torques agree? (`gipdyn inspect`)
    gipdyn::NeighbourConsistencyOptions check_options;
    check_options.joints = argv[2];
    const gipdyn::NeighbourConsistency check =
        gipdyn::neighbour_consistency(before.X, before.tau, test.X, test.tau, check_options);
    if (check.status == gipdyn::NeighbourConsistency::Status::Ok) {
      std::printf("torque at revisited states, training -> test rows: neighbour nMSE");
      for (Eigen::Index j = 0; j < check.neighbour_nmse.size(); ++j) std::printf(" %.2f", check.neighbour_nmse(j));
      std::printf(" (1 or more: the test rows follow another function of the state there)\n");
    } else {
      std::printf("neighbour check: %s\n", check.message.c_str());
    }

    std::printf("%ld training rows, %ld test rows; test nMSE per joint (1: predicting the mean):\n",
                static_cast<long>(train.rows()), static_cast<long>(test.rows()));
    if (!fit_and_test(("preset real (" + preset.name + ")").c_str(), preset, train, test, joints)) return 1;
    if (!skip_gip) {
      gipdyn::EstimatorOptions gip;  // the library's default: gip on the rows, no teacher
      gip.search.optimizer.max_iterations = preset.search.optimizer.max_iterations;
      if (!fit_and_test("gip", gip, train, test, joints)) return 1;
    }
  } catch (const gipdyn::Error& e) {
    std::fprintf(stderr, "real_log: %s\n", e.what());
    return 1;
  }
  return 0;
}
