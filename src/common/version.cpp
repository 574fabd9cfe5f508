#include "gipdyn/version.hpp"

#include <Eigen/Core>
#include <vector>

#include "gipdyn/detail/factor_pair_product.hpp"
#include "gipdyn/eigen_abi.hpp"
#include "gipdyn/error.hpp"

#ifndef GIPDYN_VERSION_STRING
#error "GIPDYN_VERSION_STRING must be defined by the build (CMake's project version)"
#endif

namespace gipdyn {
namespace {

// Read from the compiler's predefined macros of this translation unit, which
// is compiled with the library's flags.
std::string compiled_instruction_set() {
#if defined(__x86_64__)
  std::vector<std::string> extensions;
#if defined(__AVX512F__)
  extensions.push_back("AVX-512");
#endif
#if defined(__AVX2__)
  extensions.push_back("AVX2");
#endif
#if defined(__FMA__)
  extensions.push_back("FMA");
#endif
#if defined(__AVX__)
  extensions.push_back("AVX");
#endif
#if defined(__SSE4_2__)
  extensions.push_back("SSE4.2");
#endif
  return extensions.empty() ? "x86-64 (SSE2)" : "x86-64 with " + joined(extensions);
#elif defined(__aarch64__)
  return "aarch64";
#else
  return "not x86-64";
#endif
}

}  // namespace

const char* version() { return GIPDYN_VERSION_STRING; }

BuildInfo build_info() {
  BuildInfo info;
  info.instruction_set = compiled_instruction_set();
  info.eigen_version = std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) + "." +
                       std::to_string(EIGEN_MINOR_VERSION);
  info.eigen_simd = Eigen::SimdInstructionSetsInUse();
  info.eigen_static_align_bytes = EIGEN_MAX_STATIC_ALIGN_BYTES;
  info.eigen_heap_align_bytes = EIGEN_DEFAULT_ALIGN_BYTES;
  return info;
}

std::string running_cpu_features() {
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
  std::vector<std::string> features;
  if (__builtin_cpu_supports("avx512f")) features.push_back("AVX-512");
  if (__builtin_cpu_supports("avx2")) features.push_back("AVX2");
  if (__builtin_cpu_supports("fma")) features.push_back("FMA");
  if (__builtin_cpu_supports("avx")) features.push_back("AVX");
  if (__builtin_cpu_supports("sse4.2")) features.push_back("SSE4.2");
  return features.empty() ? "SSE2 only" : joined(features);
#else
  return "";
#endif
}

std::string build_summary() {
  const BuildInfo info = build_info();
  std::string line = "built for " + info.instruction_set + "; Eigen " + info.eigen_version + " (" + info.eigen_simd +
                     "), " + std::to_string(info.eigen_heap_align_bytes) + "-byte alignment";
  const std::string cpu = running_cpu_features();
  if (!cpu.empty()) line += "; running on a CPU with " + cpu;
  return line + "; GIP kernel loops in " + detail::vector_isa_name(detail::cpu_vector_isa());
}

}  // namespace gipdyn
