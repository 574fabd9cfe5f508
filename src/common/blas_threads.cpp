#include "gipdyn/blas_threads.hpp"

// Present when the BLAS is OpenBLAS; weak so that another BLAS still links.
extern "C" void openblas_set_num_threads(int) __attribute__((weak));

namespace gipdyn {

void use_single_threaded_blas() {
  if (openblas_set_num_threads) openblas_set_num_threads(1);
}

}  // namespace gipdyn
