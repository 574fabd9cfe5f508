#pragma once
// The rigid-body terms of a model whose torque is affine in qdd, from n + 2
// queries at one q, as QueryWorkspace::rigid_body_terms defines them: g(q) =
// f(q, 0, 0), M(i, j) = f_i(q, 0, e_j) - g_i(q) (row-major) and, where bias is
// not null, f(q, qd, 0). query(x, tau) answers one state; x (3n) and column
// (n) are the caller's buffers, so nothing is allocated.
#include <algorithm>

namespace gipdyn::detail {

template <class Query>
void rigid_body_terms_by_queries(int n, const double* q, const double* qd, double* x, double* column, double* gravity,
                                 double* M, double* bias, Query&& query) {
  std::fill(x, x + 3 * n, 0.0);
  std::copy(q, q + n, x);
  query(x, gravity);
  // Torque is affine in qdd: a unit acceleration of joint j gives column j of M over gravity.
  for (int j = 0; j < n; ++j) {
    x[2 * n + j] = 1.0;
    query(x, column);
    x[2 * n + j] = 0.0;
    for (int i = 0; i < n; ++i) M[i * n + j] = column[i] - gravity[i];
  }
  if (bias) {
    std::copy(qd, qd + n, x + n);
    query(x, bias);
  }
}

}  // namespace gipdyn::detail
