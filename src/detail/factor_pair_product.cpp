#include "gipdyn/detail/factor_pair_product.hpp"

namespace gipdyn::detail {
namespace {

// One body for every ISA, inlined into each ISA's function below so that the
// compiler vectorises it with that ISA's registers. This file is compiled with
// -ffp-contract=off (CMakeLists.txt): no copy may fuse a * b + c into one
// rounding, which the AVX-512 copy could otherwise do.
template <bool kWithV>
__attribute__((always_inline)) inline void factor_pair_loop(double* __restrict col, const double* __restrict u,
                                                            const double* __restrict v, std::ptrdiff_t m,
                                                            const double* p, const double* q) {
  const double p0 = p[0], p1 = p[1], p2 = p[2], q0 = q[0], q1 = q[1], q2 = q[2];
  for (std::ptrdiff_t i = 0; i < m; ++i) {
    double x = p0 + p1 * u[i], y = q0 + q1 * u[i];
    if constexpr (kWithV) {
      x = x + p2 * v[i];
      y = y + q2 * v[i];
    }
    col[i] = col[i] * (x * y);
  }
}

__attribute__((always_inline)) inline void factor_pair(double* col, const double* u, const double* v,
                                                       std::ptrdiff_t m, const double* p, const double* q) {
  if (v)
    factor_pair_loop<true>(col, u, v, m, p, q);
  else
    factor_pair_loop<false>(col, u, v, m, p, q);
}

void baseline(double* col, const double* u, const double* v, std::ptrdiff_t m, const double* p, const double* q) {
  factor_pair(col, u, v, m, p, q);
}

#if defined(__x86_64__) && defined(__GNUC__)
#define GIPDYN_HAVE_WIDE_VECTORS 1
__attribute__((target("avx2"))) void avx2(double* col, const double* u, const double* v, std::ptrdiff_t m,
                                          const double* p, const double* q) {
  factor_pair(col, u, v, m, p, q);
}

__attribute__((target("avx512f"))) void avx512(double* col, const double* u, const double* v, std::ptrdiff_t m,
                                               const double* p, const double* q) {
  factor_pair(col, u, v, m, p, q);
}
#endif

VectorIsa detect() {
#ifdef GIPDYN_HAVE_WIDE_VECTORS
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f")) return VectorIsa::kAvx512;
  if (__builtin_cpu_supports("avx2")) return VectorIsa::kAvx2;
#endif
  return VectorIsa::kBaseline;
}

// The copy of the loop for an ISA, which the caller knows this CPU runs.
void run(VectorIsa isa, double* col, const double* u, const double* v, std::ptrdiff_t m, const double* p,
         const double* q) {
  switch (isa) {
#ifdef GIPDYN_HAVE_WIDE_VECTORS
    case VectorIsa::kAvx512: return avx512(col, u, v, m, p, q);
    case VectorIsa::kAvx2: return avx2(col, u, v, m, p, q);
#endif
    default: return baseline(col, u, v, m, p, q);
  }
}

}  // namespace

VectorIsa cpu_vector_isa() {
  static const VectorIsa isa = detect();
  return isa;
}

const char* vector_isa_name(VectorIsa isa) {
  switch (isa) {
    case VectorIsa::kAvx512: return "AVX-512";
    case VectorIsa::kAvx2: return "AVX2";
    case VectorIsa::kBaseline: break;
  }
  return "SSE2";
}

bool multiply_by_factor_pair(VectorIsa isa, double* col, const double* u, const double* v, std::ptrdiff_t m,
                             const double p[3], const double q[3]) {
  if (static_cast<int>(isa) > static_cast<int>(cpu_vector_isa())) return false;
  run(isa, col, u, v, m, p, q);
  return true;
}

void multiply_by_factor_pair(double* col, const double* u, const double* v, std::ptrdiff_t m, const double p[3],
                             const double q[3]) {
  run(cpu_vector_isa(), col, u, v, m, p, q);
}

}  // namespace gipdyn::detail
