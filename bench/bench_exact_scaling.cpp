// One exact-GP NLL + gradient evaluation at a given N, and the process's peak
// memory: the cost of one optimiser step of `gipdyn train` per joint, to the
// largest N that fits. One N per process, so that the peak is that N's:
//
//   for N in 1000 2000 4000 8000 12000 16000 20000; do build/bench/bench_exact_scaling $N RRRRRRR; done
//
// Random inputs, the GIP kernel of the last joint, data-driven initial
// hyperparameters, one thread (training runs one joint per core).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/features.hpp"
#include "gipdyn/gp/exact_gp.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_exact_scaling N [JOINTS]   (JOINTS default RRRRRRR)\n");
    return 2;
  }
  const int n_rows = std::atoi(argv[1]);
  const gipdyn::JointTypes joints = gipdyn::JointTypes::parse(argc > 2 ? argv[2] : "RRRRRRR");
  gipdyn::use_single_threaded_blas();
  const gipdyn::FeatureMap features(joints);
  std::srand(7);
  const Eigen::MatrixXd Z = features.compute(Eigen::MatrixXd::Random(n_rows, 3 * joints.size()) * 2.0);
  const Eigen::VectorXd y = Eigen::VectorXd::Random(n_rows);
  auto kernel = gipdyn::make_kernel("gip", features, joints.size() - 1);
  kernel->initialize(Z, 1.0);
  gipdyn::GpWorkspace ws;
  const auto t0 = std::chrono::steady_clock::now();
  const gipdyn::NllEvaluation e = gipdyn::evaluate_nll(*kernel, -2.0, Z, y, true, ws);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  std::printf("N %d joints %s: %.2f s per NLL + gradient, peak memory %.0f MiB (8 N^2 = %.0f MiB)%s\n", n_rows,
              joints.str().c_str(), seconds, usage.ru_maxrss / 1024.0, 8.0 * n_rows * n_rows / 1048576.0,
              e.ok() ? "" : " (evaluation failed)");
  return e.ok() ? 0 : 1;
}
