#include "gipdyn/detail/blas_threads.hpp"

// Present when the BLAS is OpenBLAS; weak so that another BLAS still links.
extern "C" void openblas_set_num_threads(int) __attribute__((weak));
extern "C" int openblas_get_num_threads() __attribute__((weak));

namespace gipdyn {

void use_single_threaded_blas() {
  // Only a change is written: fits running side by side (an experiment's
  // concurrent runs) then never reconfigure the BLAS under each other.
  if (openblas_get_num_threads && openblas_get_num_threads() == 1) return;
  if (openblas_set_num_threads) openblas_set_num_threads(1);
}

}  // namespace gipdyn
