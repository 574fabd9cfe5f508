#include "gipdyn/detail/factor_pair_product.hpp"

#include <algorithm>

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

// Four doubles, in one AVX register or two SSE2 ones: GCC's vector extension,
// whose element-wise + and * are the scalar ones, lane by lane, so every copy
// gives the scalar loop's bits.
using Lanes = double __attribute__((vector_size(4 * sizeof(double))));
constexpr int kLanes = 4;

// kColumns of set_affine_combinations' outputs, kLanes rows at a time: the
// sums stay in registers while each input column streams by once for all the
// outputs, as in a BLAS kernel but without its packing.
template <int kColumns>
__attribute__((always_inline)) inline void affine_group(double* __restrict out, std::ptrdiff_t out_stride,
                                                        std::ptrdiff_t m, const double* c, const double* a,
                                                        std::ptrdiff_t stride, const double* W,
                                                        std::ptrdiff_t w_stride, int count) {
  std::ptrdiff_t i0 = 0;
  for (; i0 + kLanes <= m; i0 += kLanes) {
    Lanes sum[kColumns];
    for (int j = 0; j < kColumns; ++j) sum[j] = Lanes{} + c[j];
    for (int d = 0; d < count; ++d) {
      Lanes x;
      __builtin_memcpy(&x, a + d * stride + i0, sizeof x);
      for (int j = 0; j < kColumns; ++j) sum[j] = sum[j] + W[d + j * w_stride] * x;
    }
    for (int j = 0; j < kColumns; ++j) __builtin_memcpy(out + j * out_stride + i0, &sum[j], sizeof sum[j]);
  }
  for (; i0 < m; ++i0)
    for (int j = 0; j < kColumns; ++j) {
      double sum = c[j];
      for (int d = 0; d < count; ++d) sum = sum + W[d + j * w_stride] * a[d * stride + i0];
      out[j * out_stride + i0] = sum;
    }
}

constexpr int kMaxGroup = 8;

__attribute__((always_inline)) inline void affine_combinations(double* out, std::ptrdiff_t out_stride, int columns,
                                                               std::ptrdiff_t m, const double* c, const double* a,
                                                               std::ptrdiff_t stride, const double* W,
                                                               std::ptrdiff_t w_stride, int count) {
  for (int j0 = 0; j0 < columns; j0 += kMaxGroup) {
    double* o = out + j0 * out_stride;
    const double* cj = c + j0;
    const double* Wj = W + j0 * w_stride;
    switch (std::min(kMaxGroup, columns - j0)) {
      case 1: affine_group<1>(o, out_stride, m, cj, a, stride, Wj, w_stride, count); break;
      case 2: affine_group<2>(o, out_stride, m, cj, a, stride, Wj, w_stride, count); break;
      case 3: affine_group<3>(o, out_stride, m, cj, a, stride, Wj, w_stride, count); break;
      case 4: affine_group<4>(o, out_stride, m, cj, a, stride, Wj, w_stride, count); break;
      case 5: affine_group<5>(o, out_stride, m, cj, a, stride, Wj, w_stride, count); break;
      case 6: affine_group<6>(o, out_stride, m, cj, a, stride, Wj, w_stride, count); break;
      case 7: affine_group<7>(o, out_stride, m, cj, a, stride, Wj, w_stride, count); break;
      default: affine_group<kMaxGroup>(o, out_stride, m, cj, a, stride, Wj, w_stride, count); break;
    }
  }
}

// kInputs of add_column_dot_products' input columns against kColumns of its
// columns of U, kLanes rows at a time: one lane sum per pair in a register,
// each U column loaded once for the kInputs inputs. The lanes are then added
// in lane order, and the rows after the last whole group of lanes one by one.
template <int kInputs, int kColumns>
__attribute__((always_inline)) inline void dot_group(double* out, std::ptrdiff_t out_stride, std::ptrdiff_t m,
                                                     const double* a, std::ptrdiff_t stride, const double* U,
                                                     std::ptrdiff_t u_stride) {
  Lanes sum[kInputs][kColumns];
  for (int d = 0; d < kInputs; ++d)
    for (int j = 0; j < kColumns; ++j) sum[d][j] = Lanes{};
  std::ptrdiff_t i = 0;
  for (; i + kLanes <= m; i += kLanes) {
    Lanes x[kInputs];
    for (int d = 0; d < kInputs; ++d) __builtin_memcpy(&x[d], a + d * stride + i, sizeof x[d]);
    for (int j = 0; j < kColumns; ++j) {
      Lanes u;
      __builtin_memcpy(&u, U + j * u_stride + i, sizeof u);
      for (int d = 0; d < kInputs; ++d) sum[d][j] = sum[d][j] + x[d] * u;
    }
  }
  for (int d = 0; d < kInputs; ++d)
    for (int j = 0; j < kColumns; ++j) {
      double total = ((sum[d][j][0] + sum[d][j][1]) + sum[d][j][2]) + sum[d][j][3];
      for (std::ptrdiff_t r = i; r < m; ++r) total = total + a[d * stride + r] * U[j * u_stride + r];
      out[d + j * out_stride] = out[d + j * out_stride] + total;
    }
}

// Up to six columns of U at a time: with two inputs, twelve sums and three
// loaded vectors fill an AVX2 CPU's sixteen registers.
constexpr int kMaxDotColumns = 6;

template <int kInputs>
__attribute__((always_inline)) inline void dot_inputs(double* out, std::ptrdiff_t out_stride, int columns,
                                                      std::ptrdiff_t m, const double* a, std::ptrdiff_t stride,
                                                      const double* U, std::ptrdiff_t u_stride) {
  for (int j0 = 0; j0 < columns; j0 += kMaxDotColumns) {
    double* o = out + j0 * out_stride;
    const double* Uj = U + j0 * u_stride;
    switch (std::min(kMaxDotColumns, columns - j0)) {
      case 1: dot_group<kInputs, 1>(o, out_stride, m, a, stride, Uj, u_stride); break;
      case 2: dot_group<kInputs, 2>(o, out_stride, m, a, stride, Uj, u_stride); break;
      case 3: dot_group<kInputs, 3>(o, out_stride, m, a, stride, Uj, u_stride); break;
      case 4: dot_group<kInputs, 4>(o, out_stride, m, a, stride, Uj, u_stride); break;
      case 5: dot_group<kInputs, 5>(o, out_stride, m, a, stride, Uj, u_stride); break;
      default: dot_group<kInputs, kMaxDotColumns>(o, out_stride, m, a, stride, Uj, u_stride); break;
    }
  }
}

__attribute__((always_inline)) inline void column_dot_products(double* out, std::ptrdiff_t out_stride, int count,
                                                               int columns, std::ptrdiff_t m, const double* a,
                                                               std::ptrdiff_t stride, const double* U,
                                                               std::ptrdiff_t u_stride) {
  int d = 0;
  for (; d + 2 <= count; d += 2) dot_inputs<2>(out + d, out_stride, columns, m, a + d * stride, stride, U, u_stride);
  if (d < count) dot_inputs<1>(out + d, out_stride, columns, m, a + d * stride, stride, U, u_stride);
}

// Each ISA's copy of the loops.
#define GIPDYN_LOOPS(ATTRIBUTE, SUFFIX)                                                                          \
  ATTRIBUTE void factor_pair_##SUFFIX(double* col, const double* u, const double* v, std::ptrdiff_t m,           \
                                      const double* p, const double* q) {                                       \
    factor_pair(col, u, v, m, p, q);                                                                            \
  }                                                                                                             \
  ATTRIBUTE void affine_##SUFFIX(double* out, std::ptrdiff_t out_stride, int columns, std::ptrdiff_t m,         \
                                 const double* c, const double* a, std::ptrdiff_t stride, const double* W,       \
                                 std::ptrdiff_t w_stride, int count) {                                          \
    affine_combinations(out, out_stride, columns, m, c, a, stride, W, w_stride, count);                         \
  }                                                                                                             \
  ATTRIBUTE void dots_##SUFFIX(double* out, std::ptrdiff_t out_stride, int count, int columns, std::ptrdiff_t m, \
                               const double* a, std::ptrdiff_t stride, const double* U, std::ptrdiff_t u_stride) { \
    column_dot_products(out, out_stride, count, columns, m, a, stride, U, u_stride);                            \
  }

GIPDYN_LOOPS(, baseline)
#if defined(__x86_64__) && defined(__GNUC__)
#define GIPDYN_HAVE_WIDE_VECTORS 1
GIPDYN_LOOPS(__attribute__((target("avx2"))), avx2)
GIPDYN_LOOPS(__attribute__((target("avx512f"))), avx512)
#endif
#undef GIPDYN_LOOPS

VectorIsa detect() {
#ifdef GIPDYN_HAVE_WIDE_VECTORS
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512f")) return VectorIsa::kAvx512;
  if (__builtin_cpu_supports("avx2")) return VectorIsa::kAvx2;
#endif
  return VectorIsa::kBaseline;
}

// A loop's three copies, in VectorIsa's order (baseline, AVX2, AVX-512);
// without wide vectors, the baseline copy three times.
#ifdef GIPDYN_HAVE_WIDE_VECTORS
#define GIPDYN_COPIES(LOOP) LOOP##_baseline, LOOP##_avx2, LOOP##_avx512
#else
#define GIPDYN_COPIES(LOOP) LOOP##_baseline, LOOP##_baseline, LOOP##_baseline
#endif

// The copy of a loop for an ISA, which the caller knows this CPU runs.
template <class Loop>
Loop* copy_for(VectorIsa isa, Loop* baseline, Loop* avx2, Loop* avx512) {
  switch (isa) {
    case VectorIsa::kAvx512: return avx512;
    case VectorIsa::kAvx2: return avx2;
    case VectorIsa::kBaseline: break;
  }
  return baseline;
}

bool runs_on_this_cpu(VectorIsa isa) { return static_cast<int>(isa) <= static_cast<int>(cpu_vector_isa()); }

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
  if (!runs_on_this_cpu(isa)) return false;
  copy_for(isa, GIPDYN_COPIES(factor_pair))(col, u, v, m, p, q);
  return true;
}

void multiply_by_factor_pair(double* col, const double* u, const double* v, std::ptrdiff_t m, const double p[3],
                             const double q[3]) {
  multiply_by_factor_pair(cpu_vector_isa(), col, u, v, m, p, q);
}

bool set_affine_combinations(VectorIsa isa, double* out, std::ptrdiff_t out_stride, int columns, std::ptrdiff_t m,
                             const double* c, const double* a, std::ptrdiff_t stride, const double* W,
                             std::ptrdiff_t w_stride, int count) {
  if (!runs_on_this_cpu(isa)) return false;
  copy_for(isa, GIPDYN_COPIES(affine))(out, out_stride, columns, m, c, a, stride, W, w_stride, count);
  return true;
}

void set_affine_combinations(double* out, std::ptrdiff_t out_stride, int columns, std::ptrdiff_t m, const double* c,
                             const double* a, std::ptrdiff_t stride, const double* W, std::ptrdiff_t w_stride,
                             int count) {
  set_affine_combinations(cpu_vector_isa(), out, out_stride, columns, m, c, a, stride, W, w_stride, count);
}

bool add_column_dot_products(VectorIsa isa, double* out, std::ptrdiff_t out_stride, int count, int columns,
                             std::ptrdiff_t m, const double* a, std::ptrdiff_t stride, const double* U,
                             std::ptrdiff_t u_stride) {
  if (!runs_on_this_cpu(isa)) return false;
  copy_for(isa, GIPDYN_COPIES(dots))(out, out_stride, count, columns, m, a, stride, U, u_stride);
  return true;
}

void add_column_dot_products(double* out, std::ptrdiff_t out_stride, int count, int columns, std::ptrdiff_t m,
                             const double* a, std::ptrdiff_t stride, const double* U, std::ptrdiff_t u_stride) {
  add_column_dot_products(cpu_vector_isa(), out, out_stride, count, columns, m, a, stride, U, u_stride);
}

#undef GIPDYN_COPIES

}  // namespace gipdyn::detail
