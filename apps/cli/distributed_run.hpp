#pragma once
// `gipdyn train --distributed`: the same command on every MPI process. Each
// process reads the data and checks the options; they agree that all of them
// could before the collective training starts, so that one process's bad file
// never leaves the others waiting. Only the first process prints and writes.
#include <memory>
#include <stdexcept>
#include <string>

#include "gipdyn/gp/nll_backend.hpp"

namespace gipdyn::cli {

// Whether this gipdyn can train with --distributed (MPI and ScaLAPACK found at build time).
bool built_with_mpi();

// Thrown on the processes that stay silent about an error another process
// reports; main() exits with status 1 without a message.
struct ExitQuietly : std::runtime_error {
  ExitQuietly() : std::runtime_error("exit quietly") {}
};

class DistributedRun {
 public:
  // Initialises MPI (throws gipdyn::Error when gipdyn was built without it).
  DistributedRun();
  ~DistributedRun();
  DistributedRun(const DistributedRun&) = delete;
  DistributedRun& operator=(const DistributedRun&) = delete;

  bool is_root() const;
  int size() const;
  std::shared_ptr<NllBackend> backend() const;
  // Collective: returns when every process got here without an error;
  // otherwise one process throws its error and the others throw ExitQuietly.
  void agree(const std::string& error) const;
  // An error during the collective part: the first process reports it (the
  // library's collective errors are the same everywhere), the others stay
  // silent. Anything else than a gipdyn::Error may have struck one process
  // only: it aborts every process. Never returns.
  [[noreturn]] void fail(std::exception_ptr error) const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace gipdyn::cli
