#include "distributed_run.hpp"

#include <iostream>
#include <string>

#include "exit_codes.hpp"
#include "gipdyn/error.hpp"

#ifdef GIPDYN_HAVE_MPI
#include "gipdyn/distributed/distributed_nll.hpp"
#endif

namespace gipdyn::cli {

#ifdef GIPDYN_HAVE_MPI

struct DistributedRun::State {
  MpiSession session{nullptr, nullptr};
  std::shared_ptr<DistributedNll> backend = std::make_shared<DistributedNll>(MPI_COMM_WORLD);
};

DistributedRun::DistributedRun() : state_(std::make_unique<State>()) {}
DistributedRun::~DistributedRun() = default;
bool DistributedRun::is_root() const { return state_->session.rank() == 0; }
int DistributedRun::size() const { return state_->session.size(); }
std::shared_ptr<NllBackend> DistributedRun::backend() const { return state_->backend; }

void DistributedRun::agree(const std::string& error) const {
  int ok = error.empty() ? 1 : 0, all_ok = ok, root_ok = ok;
  MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  MPI_Bcast(&root_ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (all_ok) return;
  const int rank = state_->session.rank();
  if (ok || (rank != 0 && !root_ok)) throw ExitQuietly();  // the first process speaks for all when it failed too
  throw Error(rank == 0 ? error
                        : "MPI process " + std::to_string(rank) + " of " + std::to_string(size()) + ": " + error);
}

void DistributedRun::fail(std::exception_ptr error) const {
  try {
    std::rethrow_exception(error);
  } catch (const Error&) {
    if (is_root()) throw;
    throw ExitQuietly();
  } catch (const ExitQuietly&) {
    throw;
  } catch (const std::exception& e) {
    print_error("MPI process " + std::to_string(state_->session.rank()) + ": " + e.what() + "; stopping every process");
  } catch (...) {
    print_error("MPI process " + std::to_string(state_->session.rank()) + " failed; stopping every process");
  }
  MPI_Abort(MPI_COMM_WORLD, 1);
  throw ExitQuietly();  // not reached
}

bool built_with_mpi() { return true; }

#else

bool built_with_mpi() { return false; }

struct DistributedRun::State {};

DistributedRun::DistributedRun() {
  throw Error(
      "distributed training needs a gipdyn built with MPI and ScaLAPACK: install libopenmpi-dev "
      "libscalapack-openmpi-dev openmpi-bin and rebuild (CMake finds them)");
}
DistributedRun::~DistributedRun() = default;
bool DistributedRun::is_root() const { return true; }
int DistributedRun::size() const { return 1; }
std::shared_ptr<NllBackend> DistributedRun::backend() const { return nullptr; }
void DistributedRun::agree(const std::string&) const {}
void DistributedRun::fail(std::exception_ptr error) const { std::rethrow_exception(error); }

#endif

}  // namespace gipdyn::cli
