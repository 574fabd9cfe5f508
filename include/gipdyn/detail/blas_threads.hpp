#pragma once
// gipdyn runs BLAS on one thread and parallelises over joints itself
// (docs/method.md section 5: a multi-threaded BLAS next to a busy core waits for it). One
// thread everywhere also makes results independent of the machine's core
// count: the same model predicts bit-identically in every process.

namespace gipdyn {

// Sets OpenBLAS to one thread (a no-op with another BLAS). Cheap; called by
// every library entry point that runs large BLAS operations.
void use_single_threaded_blas();

}  // namespace gipdyn
