#pragma once
// The exact GP's NLL, gradient and weights across MPI processes (ScaLAPACK).
// Built only when CMake finds MPI and ScaLAPACK (target gipdyn::distributed).
//
// Every process holds all training rows (N x feature_dim, small) and its
// block-cyclic share of the N x N kernel matrix, about N^2 / P entries:
//   K      built locally from the rows and columns the process owns,
//   L      pdpotrf (with the same jitter policy as one process),
//   alpha  pdpotrs, summed to every process (an N-vector),
//   K^-1   pdpotri, so that W = alpha alpha^T - K^-1 is local too and each
//          process contracts its block of W with the kernel's gradient
//          (Kernel::contract_cross); one MPI_Allreduce sums the gradient.
// The optimiser runs on every process with identical values, so every process
// walks the same path: train_model with TrainOptions::nll_backend set to a
// DistributedNll, called on every process with the same data, is a
// distributed training with the same optimiser and the same model as one process.
#include <mpi.h>

#include <memory>
#include <string>

#include "gipdyn/gp/nll_backend.hpp"

namespace gipdyn {

// MPI_Init_thread for a program that may or may not run under mpirun; finalises
// on destruction if it initialised. One per program, before any DistributedNll.
class MpiSession {
 public:
  MpiSession(int* argc, char*** argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  bool owns_ = false;
  int rank_ = 0, size_ = 1;
};

class DistributedNll : public NllBackend {
 public:
  // Collective over comm (which must outlive this object). block_size: the
  // rows and columns of ScaLAPACK's square blocks; 64 suits OpenBLAS.
  explicit DistributedNll(MPI_Comm comm = MPI_COMM_WORLD, int block_size = 64);
  ~DistributedNll() override;
  DistributedNll(const DistributedNll&) = delete;
  DistributedNll& operator=(const DistributedNll&) = delete;

  NllEvaluation evaluate(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                         const Eigen::VectorXd& y, bool with_gradient, Eigen::VectorXd* alpha,
                         const JitterPolicy& jitter) override;
  // Refuses, on every process at once, when the processes were given different
  // data, or when one of them cannot hold its share of the N x N matrices.
  void plan(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& Y) override;
  std::string describe() const override;

  int rank() const { return rank_; }
  int size() const { return size_; }
  int grid_rows() const { return grid_rows_; }
  int grid_cols() const { return grid_cols_; }
  // Bytes one process needs for N training rows (its largest share).
  double bytes_per_process(long rows) const;

 private:
  MPI_Comm comm_;
  int block_ = 64;
  int rank_ = 0, size_ = 1;
  int system_handle_ = -1, context_ = -1;  // BLACS: the communicator's handle, the grid's context
  int grid_rows_ = 1, grid_cols_ = 1, my_row_ = 0, my_col_ = 0;
};

}  // namespace gipdyn
