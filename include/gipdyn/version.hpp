#pragma once
// Which gipdyn this is: model files record it beside their format version,
// and every front end prints it (gipdyn --version, gipdyn.__version__,
// gipdyn_version()), with how the library was compiled (build_info), so that
// a bug report says which instruction set and Eigen layout it ran with.
#include <string>

namespace gipdyn {

// The project's version, e.g. "0.1.0" (CMake's project version).
const char* version();

// How this library was compiled. Fixed when the library is built; the same
// for every call.
struct BuildInfo {
  // The x86-64 instruction set the compiler was allowed to use, from the
  // baseline up: "x86-64 (SSE2)", then SSE4.2, AVX, AVX2, FMA, AVX-512 where
  // enabled (gipdyn's default build is the baseline; GIPDYN_NATIVE adds this
  // CPU's extensions below AVX). Other architectures give their name.
  std::string instruction_set;
  // Eigen's version and the SIMD instruction sets its code uses.
  std::string eigen_version;
  std::string eigen_simd;
  // Eigen's alignment of fixed-size objects and of heap blocks, in bytes: 16
  // in every build gipdyn allows (eigen_abi.hpp), the layout of Debian's
  // libraries that gipdyn shares Eigen objects with.
  int eigen_static_align_bytes = 0;
  int eigen_heap_align_bytes = 0;
};
BuildInfo build_info();

// The extensions of the CPU this process runs on ("AVX-512, AVX2, FMA, AVX,
// SSE4.2" or "SSE2 only"), for the same bug reports; on other architectures
// an empty string.
std::string running_cpu_features();

// One line for --version and bug reports: the build's instruction set, Eigen
// and its alignment, the CPU it runs on, and the vector instructions the GIP
// kernel's innermost loops use there (chosen at run time, whatever the build).
std::string build_summary();

}  // namespace gipdyn
