#pragma once
// Internal, not a stable API: the GIP kernel's innermost loops in the widest
// vector instructions of the CPU it runs on. The library and Eigen are compiled
// for the baseline instruction set (eigen_abi.hpp says why); these loops touch
// only raw arrays, so a copy of them compiled for AVX2 or AVX-512 shares no
// Eigen object with anything, and the copy is chosen when the program runs.
#include <cstddef>

namespace gipdyn::detail {

enum class VectorIsa { kBaseline, kAvx2, kAvx512 };

// The widest of kAvx512 (AVX-512F), kAvx2 and kBaseline this CPU runs; read once.
VectorIsa cpu_vector_isa();
const char* vector_isa_name(VectorIsa isa);  // "SSE2", "AVX2", "AVX-512"

// col[i] *= (p[0] + p[1] u[i] + p[2] v[i]) * (q[0] + q[1] u[i] + q[2] v[i]) for
// i < m; with v null the v terms are left out. The two factors of one joint's
// position kernel read the same columns, hence one pass for both. Every ISA
// gives the same bits: element-wise sums and products in this order, no fused
// multiply-add. The arrays must not overlap.
void multiply_by_factor_pair(double* col, const double* u, const double* v, std::ptrdiff_t m, const double p[3],
                             const double q[3]);
// The same with a given ISA (the tests compare them); false, with col
// untouched, where this CPU does not run that ISA.
bool multiply_by_factor_pair(VectorIsa isa, double* col, const double* u, const double* v, std::ptrdiff_t m,
                             const double p[3], const double q[3]);

// out[i + j out_stride] = c[j] + W[j w_stride] a[i] + W[1 + j w_stride]
// a[stride + i] + ... + W[count - 1 + j w_stride] a[(count - 1) stride + i]
// for i < m and j < columns, added in that order: a product of count columns
// of a column-major matrix a with a count x columns matrix W (column stride
// w_stride), plus c, which is how a GIP kernel's row starts for every joint at
// once (its acceleration factor). A BLAS product spends longer packing its
// operands than multiplying at so few columns. Every ISA gives the same bits,
// as above. out must not overlap the inputs.
void set_affine_combinations(double* out, std::ptrdiff_t out_stride, int columns, std::ptrdiff_t m, const double* c,
                             const double* a, std::ptrdiff_t stride, const double* W, std::ptrdiff_t w_stride,
                             int count);
bool set_affine_combinations(VectorIsa isa, double* out, std::ptrdiff_t out_stride, int columns, std::ptrdiff_t m,
                             const double* c, const double* a, std::ptrdiff_t stride, const double* W,
                             std::ptrdiff_t w_stride, int count);
// out[d + j out_stride] += the dot product of a's column d (a[d stride + i],
// i < m) with U's column j (U[j u_stride + i]), for d < count and j < columns:
// a transposed product, which is how the affine coefficients of every
// joint's GIP prediction are summed. Each dot product runs in four lanes
// (rows i = l mod 4 in lane l), added in lane order, then the last m mod 4
// rows in order: the same bits on every ISA. out must not overlap the inputs.
void add_column_dot_products(double* out, std::ptrdiff_t out_stride, int count, int columns, std::ptrdiff_t m,
                             const double* a, std::ptrdiff_t stride, const double* U, std::ptrdiff_t u_stride);
bool add_column_dot_products(VectorIsa isa, double* out, std::ptrdiff_t out_stride, int count, int columns,
                             std::ptrdiff_t m, const double* a, std::ptrdiff_t stride, const double* U,
                             std::ptrdiff_t u_stride);

}  // namespace gipdyn::detail
