// Distributed NLL + gradient (MPI + ScaLAPACK) against the in-process one.
//
//   mpirun -np P build/bench/bench_distributed [ROWS...]      (default 1000 2000 4000)
//   (environment GIPDYN_BLOCK=b: ScaLAPACK blocks of b rows instead of 64)
//
// For each N: a 6R arm's GIP kernel on random inputs, one warm-up evaluation,
// then the median of 3 timed evaluations with the gradient, on P processes;
// with -np 1 also the in-process evaluate_nll (training's path) for comparison.
// Plain timing rather than Google Benchmark: every process must run the same
// number of evaluations, which Benchmark's adaptive iteration counts cannot
// promise. The first process prints one line per N.
#include <mpi.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "gipdyn/detail/blas_threads.hpp"
#include "gipdyn/distributed/distributed_nll.hpp"
#include "gipdyn/features.hpp"
#include "gipdyn/kernels/kernel_factory.hpp"
#include "gipdyn/memory.hpp"

namespace {

template <class F>
double median_seconds(F&& evaluate, MPI_Comm comm) {
  evaluate();  // warm-up: first-touch of the buffers
  std::vector<double> t;
  for (int r = 0; r < 3; ++r) {
    MPI_Barrier(comm);
    const double t0 = MPI_Wtime();
    evaluate();
    MPI_Barrier(comm);
    t.push_back(MPI_Wtime() - t0);
  }
  std::sort(t.begin(), t.end());
  return t[1];
}

}  // namespace

int main(int argc, char** argv) {
  gipdyn::MpiSession mpi(&argc, &argv);
  std::vector<int> sizes;
  for (int a = 1; a < argc; ++a) sizes.push_back(std::atoi(argv[a]));
  if (sizes.empty()) sizes = {1000, 2000, 4000};
  gipdyn::use_single_threaded_blas();  // one core per process, as in training

  const gipdyn::JointTypes joints = gipdyn::JointTypes::parse("RRRRRR");
  const gipdyn::FeatureMap features(joints);
  // GIPDYN_BLOCK: ScaLAPACK's block size (default 64).
  const char* block = std::getenv("GIPDYN_BLOCK");
  gipdyn::DistributedNll backend(MPI_COMM_WORLD, block ? std::atoi(block) : 64);
  if (mpi.rank() == 0)
    std::printf("%-6s %-10s %-22s %-22s\n", "N", "processes", "distributed s/eval", "in-process s/eval");
  for (const int n : sizes) {
    std::srand(7);
    const Eigen::MatrixXd X = Eigen::MatrixXd::Random(n, 18) * 2.0;
    const Eigen::MatrixXd Z = features.compute(X);
    const Eigen::VectorXd y = Eigen::VectorXd::Random(n);
    auto kernel = gipdyn::make_kernel("gip", features, 0);
    kernel->initialize(Z, 1.0);
    const double dist = median_seconds(
        [&] { backend.evaluate(*kernel, -2.0, Z, y, true, nullptr, gipdyn::JitterPolicy{}); }, MPI_COMM_WORLD);
    double single = -1.0;
    if (mpi.size() == 1) {
      gipdyn::GpWorkspace ws;
      single = median_seconds([&] { gipdyn::evaluate_nll(*kernel, -2.0, Z, y, true, ws); }, MPI_COMM_WORLD);
    }
    if (mpi.rank() == 0) {
      std::printf("%-6d %-10d %-22.3f ", n, mpi.size(), dist);
      if (single > 0) std::printf("%-22.3f\n", single);
      else std::printf("%-22s\n", "-");
      std::fflush(stdout);
    }
  }
  return 0;
}
