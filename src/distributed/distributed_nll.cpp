#include "gipdyn/distributed/distributed_nll.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "gipdyn/error.hpp"
#include "gipdyn/memory.hpp"

// BLACS and ScaLAPACK have no C header in Debian; these are their C and Fortran entry points.
extern "C" {
int Csys2blacs_handle(MPI_Comm comm);
void Cfree_blacs_system_handle(int handle);
void Cblacs_gridinit(int* context, const char* order, int nprow, int npcol);
void Cblacs_gridinfo(int context, int* nprow, int* npcol, int* myrow, int* mycol);
void Cblacs_gridexit(int context);
int numroc_(const int* n, const int* nb, const int* iproc, const int* isrcproc, const int* nprocs);
void descinit_(int* desc, const int* m, const int* n, const int* mb, const int* nb, const int* irsrc, const int* icsrc,
               const int* ictxt, const int* lld, int* info);
void pdpotrf_(const char* uplo, const int* n, double* a, const int* ia, const int* ja, const int* desca, int* info);
void pdpotri_(const char* uplo, const int* n, double* a, const int* ia, const int* ja, const int* desca, int* info);
void pdpotrs_(const char* uplo, const int* n, const int* nrhs, const double* a, const int* ia, const int* ja,
              const int* desca, double* b, const int* ib, const int* jb, const int* descb, int* info);
}

namespace gipdyn {
namespace {

constexpr int kOne = 1, kZero = 0;
// Columns per panel of the kernel's values and the gradient's weights (at least one block).
constexpr int kPanelColumns = 256;

// The global indices of the rows (or columns) a process owns, in its local
// order: block-cyclic with square blocks, the first block on process 0.
std::vector<Eigen::Index> owned_indices(Eigen::Index n, int block, int me, int procs) {
  std::vector<Eigen::Index> idx;
  for (Eigen::Index first = static_cast<Eigen::Index>(me) * block; first < n;
       first += static_cast<Eigen::Index>(procs) * block)
    for (Eigen::Index g = first; g < std::min<Eigen::Index>(n, first + block); ++g) idx.push_back(g);
  return idx;
}

// (local row, local column) of every diagonal entry a process holds.
std::vector<std::pair<Eigen::Index, Eigen::Index>> diagonal_entries(const std::vector<Eigen::Index>& rows,
                                                                  const std::vector<Eigen::Index>& cols) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> d;
  size_t i = 0, j = 0;
  while (i < rows.size() && j < cols.size()) {
    if (rows[i] == cols[j]) d.emplace_back(static_cast<Eigen::Index>(i++), static_cast<Eigen::Index>(j++));
    else if (rows[i] < cols[j]) ++i;
    else ++j;
  }
  return d;
}

// Local columns [col, col + width) and the local rows from `row` on: every
// entry on or below the diagonal in those columns.
struct Panel {
  Eigen::Index col, width, row;
};

std::vector<Panel> lower_panels(const std::vector<Eigen::Index>& rows, const std::vector<Eigen::Index>& cols,
                                Eigen::Index width) {
  std::vector<Panel> panels;
  for (size_t j0 = 0; j0 < cols.size(); j0 += static_cast<size_t>(width)) {
    Panel p;
    p.col = static_cast<Eigen::Index>(j0);
    p.width = std::min<Eigen::Index>(width, static_cast<Eigen::Index>(cols.size() - j0));
    p.row = std::lower_bound(rows.begin(), rows.end(), cols[j0]) - rows.begin();
    if (p.row < static_cast<Eigen::Index>(rows.size())) panels.push_back(p);
  }
  return panels;
}

double sum_all(double local, MPI_Comm comm) {
  MPI_Allreduce(MPI_IN_PLACE, &local, 1, MPI_DOUBLE, MPI_SUM, comm);
  return local;
}

// True on every process when every process's value is true.
bool all_true(bool local, MPI_Comm comm) {
  int v = local ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_INT, MPI_MIN, comm);
  return v == 1;
}

// True on every process when every process holds the same vector (bit for bit).
bool same_everywhere(const std::vector<double>& v, MPI_Comm comm) {
  std::vector<double> lo = v, hi = v;
  const int n = static_cast<int>(v.size());
  MPI_Allreduce(MPI_IN_PLACE, lo.data(), n, MPI_DOUBLE, MPI_MIN, comm);
  MPI_Allreduce(MPI_IN_PLACE, hi.data(), n, MPI_DOUBLE, MPI_MAX, comm);
  return lo == hi;
}

// Order-sensitive fingerprints of a matrix: its sum and its row-weighted sum.
void fingerprint(const Eigen::MatrixXd& M, std::vector<double>& out) {
  out.push_back(static_cast<double>(M.rows()));
  out.push_back(static_cast<double>(M.cols()));
  out.push_back(M.sum());
  const Eigen::VectorXd w = Eigen::VectorXd::LinSpaced(M.rows(), 1.0, static_cast<double>(M.rows()));
  out.push_back((w.transpose() * M).sum());
}

// Whether every process evaluates the same hyperparameters on the same targets.
bool same_evaluation_everywhere(const Kernel& kernel, double log_noise_variance, const Eigen::VectorXd& y,
                                MPI_Comm comm) {
  const Eigen::VectorXd p = kernel.log_params();
  std::vector<double> v(p.data(), p.data() + p.size());
  v.push_back(log_noise_variance);
  v.push_back(static_cast<double>(y.size()));
  v.push_back(y.sum());
  return same_everywhere(v, comm);
}

// This process's share of the kernel's gradient contraction with W = alpha
// alpha^T - K^-1, from the lower triangle of K^-1 in A (local rows x local
// columns): below the diagonal W counts twice (W and dK are symmetric), the
// diagonal once.
void contract_lower_panels(const Kernel& kernel, const std::vector<Panel>& panels,
                           const std::vector<Eigen::Index>& rows, const std::vector<Eigen::Index>& cols,
                           const Eigen::MatrixXd& Zr, const Eigen::MatrixXd& Zc, const Eigen::VectorXd& alpha,
                           const Eigen::MatrixXd& A, Eigen::Ref<Eigen::VectorXd> grad) {
  const Eigen::Index mloc = static_cast<Eigen::Index>(rows.size());
  KernelScratch scratch;
  Eigen::MatrixXd W;
  for (const Panel& p : panels) {
    const Eigen::Index m = mloc - p.row;
    W.resize(m, p.width);
    for (Eigen::Index j = 0; j < p.width; ++j) {
      const Eigen::Index gj = cols[static_cast<size_t>(p.col + j)];
      for (Eigen::Index i = 0; i < m; ++i) {
        const Eigen::Index gi = rows[static_cast<size_t>(p.row + i)];
        const double w = alpha(gi) * alpha(gj) - A(p.row + i, p.col + j);
        W(i, j) = gi > gj ? 2.0 * w : gi == gj ? w : 0.0;
      }
    }
    kernel.contract_cross(Zr.bottomRows(m), Zc.middleRows(p.col, p.width), W, grad, scratch);
  }
}

}  // namespace

MpiSession::MpiSession(int* argc, char*** argv) {
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (!initialised) {
    int provided = 0;
    // Only the main thread calls MPI; the library's other threads never do.
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    owns_ = true;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

MpiSession::~MpiSession() {
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (owns_ && !finalised) MPI_Finalize();
}

DistributedNll::DistributedNll(MPI_Comm comm, int block_size) : comm_(comm), block_(block_size) {
  if (block_size < 1) throw Error("DistributedNll: block_size must be >= 1");
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (!initialised) throw Error("DistributedNll needs MPI initialised first (an MpiSession)");
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
  // The squarest grid: the fewest rows and columns each process owns.
  grid_rows_ = 1;
  for (int r = 1; r * r <= size_; ++r)
    if (size_ % r == 0) grid_rows_ = r;
  grid_cols_ = size_ / grid_rows_;
  system_handle_ = Csys2blacs_handle(comm_);
  context_ = system_handle_;
  Cblacs_gridinit(&context_, "Row", grid_rows_, grid_cols_);
  int rows = 0, cols = 0;
  Cblacs_gridinfo(context_, &rows, &cols, &my_row_, &my_col_);
}

DistributedNll::~DistributedNll() {
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (finalised) return;
  if (context_ >= 0) Cblacs_gridexit(context_);
  if (system_handle_ >= 0) Cfree_blacs_system_handle(system_handle_);
}

std::string DistributedNll::describe() const {
  std::ostringstream s;
  s << size_ << " MPI process" << (size_ == 1 ? "" : "es") << ", a " << grid_rows_ << " x " << grid_cols_
    << " ScaLAPACK grid of " << block_ << "-row blocks";
  return s.str();
}

double DistributedNll::bytes_per_process(long rows) const {
  const int n = static_cast<int>(rows);
  const int zero = 0;
  const double m = numroc_(&n, &block_, &zero, &zero, &grid_rows_);  // process 0 holds the most
  const double c = numroc_(&n, &block_, &zero, &zero, &grid_cols_);
  // The matrix (K, its factor, then K^-1), and per panel of columns the
  // kernel's values, the weights W and the contraction's scratch.
  return 8.0 * m * c + 3.0 * 8.0 * m * std::min<double>(c, std::max(block_, kPanelColumns));
}

void DistributedNll::plan(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& Y) {
  std::vector<double> v;
  fingerprint(Z, v);
  fingerprint(Y, v);
  if (!same_everywhere(v, comm_))
    throw Error("the MPI processes were given different training data (row count, columns or values differ): "
                "start every process with the same data and options");
  if (Z.rows() > 2147483647L / 2) throw Error("distributed training supports at most 1073741823 rows");
  const double need = bytes_per_process(Z.rows());
  const double have = static_cast<double>(available_memory_bytes());
  if (!all_true(need <= have, comm_))
    throw Error("distributed training on " + std::to_string(Z.rows()) + " rows needs about " + format_bytes(need) +
                " per process, more than a process has available (" + format_bytes(have) + " on process " +
                std::to_string(rank_) + "); start more processes, on more machines, or train on fewer rows");
}

NllEvaluation DistributedNll::evaluate(const Kernel& kernel, double log_noise_variance, const Eigen::MatrixXd& Z,
                                       const Eigen::VectorXd& y, bool with_gradient, Eigen::VectorXd* alpha_out,
                                       const JitterPolicy& policy) {
  NllEvaluation out;
  const int P = kernel.num_params();
  if (!same_evaluation_everywhere(kernel, log_noise_variance, y, comm_)) {
    out.message = "the MPI processes disagree on the hyperparameters or targets of this evaluation; every process "
                  "must run the same training";
    return out;
  }
  const int N = static_cast<int>(Z.rows());
  const double noise = std::exp(log_noise_variance);
  const std::vector<Eigen::Index> rows = owned_indices(N, block_, my_row_, grid_rows_);
  const std::vector<Eigen::Index> cols = owned_indices(N, block_, my_col_, grid_cols_);
  const auto diag = diagonal_entries(rows, cols);
  const Eigen::MatrixXd Zr = Z(rows, Eigen::all), Zc = Z(cols, Eigen::all);
  const int mloc = static_cast<int>(rows.size()), nloc = static_cast<int>(cols.size());
  const int lld = std::max(1, mloc);
  int desc[9], info = 0;
  descinit_(desc, &N, &N, &block_, &block_, &kZero, &kZero, &context_, &lld, &info);

  // Only the lower triangle is read, so the kernel is evaluated on panels of
  // local columns and the rows at or below each panel's first column: about
  // half the entries (the rest of the upper triangle is zero).
  const std::vector<Panel> panels = lower_panels(rows, cols, std::max(block_, kPanelColumns));
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(mloc, nloc), Kp;
  auto build = [&](double diag_add) {
    for (const Panel& p : panels) {
      kernel.cross(Zr.bottomRows(mloc - p.row), Zc.middleRows(p.col, p.width), Kp);
      A.block(p.row, p.col, mloc - p.row, p.width) = Kp;
    }
    for (const auto& [i, j] : diag) A(i, j) += diag_add;
  };
  build(noise);
  double local_trace = 0.0;
  for (const auto& [i, j] : diag) local_trace += A(i, j);
  const double mean_diag = sum_all(local_trace, comm_) / N;
  if (!all_true(A.allFinite() && std::isfinite(mean_diag), comm_)) {
    out.status = NllEvaluation::Status::NonFinite;
    out.message = "kernel matrix has NaN or Inf entries (check the inputs and the hyperparameters)";
    return out;
  }

  const CholeskyResult chol = factorize_with_jitter(
      mean_diag,
      [&](double jitter) {
        if (jitter > 0.0) build(noise + jitter);
        pdpotrf_("L", &N, A.data(), &kOne, &kOne, desc, &info);
        return all_true(info == 0, comm_);
      },
      policy);
  out.jitter = chol.jitter;
  if (!chol.ok()) {
    out.status = NllEvaluation::Status::NotPositiveDefinite;
    out.message = chol.message;
    return out;
  }

  double local_logdet = 0.0;
  for (const auto& [i, j] : diag) local_logdet += 2.0 * std::log(A(i, j));
  const double logdet = sum_all(local_logdet, comm_);

  // alpha = K^-1 y: the vector lives in the grid's first process column.
  const int bcols = numroc_(&kOne, &block_, &my_col_, &kZero, &grid_cols_);
  Eigen::VectorXd b = bcols > 0 ? Eigen::VectorXd(y(rows)) : Eigen::VectorXd();
  int bdesc[9];
  descinit_(bdesc, &N, &kOne, &block_, &block_, &kZero, &kZero, &context_, &lld, &info);
  pdpotrs_("L", &N, &kOne, A.data(), &kOne, &kOne, desc, b.data(), &kOne, &kOne, bdesc, &info);
  Eigen::VectorXd alpha = Eigen::VectorXd::Zero(N);
  if (bcols > 0) alpha(rows) = b;
  MPI_Allreduce(MPI_IN_PLACE, alpha.data(), N, MPI_DOUBLE, MPI_SUM, comm_);

  out.nll = gaussian_nll(y.dot(alpha), logdet, N);
  // MPI does not promise bit-identical reductions on every process; the
  // optimisers stay in step only if they see identical values, so the first
  // process's are everyone's.
  MPI_Bcast(&out.nll, 1, MPI_DOUBLE, 0, comm_);
  if (!std::isfinite(out.nll)) {
    out.message = "marginal likelihood is not finite at these hyperparameters";
    return out;
  }
  out.status = NllEvaluation::Status::Ok;
  if (alpha_out) {
    MPI_Bcast(alpha.data(), N, MPI_DOUBLE, 0, comm_);
    *alpha_out = alpha;
  }
  if (!with_gradient) return out;

  pdpotri_("L", &N, A.data(), &kOne, &kOne, desc, &info);
  if (!all_true(info == 0, comm_)) {
    out.status = NllEvaluation::Status::InversionFailed;
    out.message = "could not invert the kernel matrix (ScaLAPACK pdpotri failed)";
    return out;
  }
  // Only the lower triangle of K^-1 is there: W = alpha alpha^T - K^-1 below
  // the diagonal counts twice (W and dK are symmetric), the diagonal once.
  double local_inverse_trace = 0.0;
  for (const auto& [i, j] : diag) local_inverse_trace += A(i, j);
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(P + 1);
  contract_lower_panels(kernel, panels, rows, cols, Zr, Zc, alpha, A, grad.head(P));
  grad(P) = local_inverse_trace;
  MPI_Allreduce(MPI_IN_PLACE, grad.data(), P + 1, MPI_DOUBLE, MPI_SUM, comm_);
  out.gradient = Eigen::VectorXd(P + 1);
  out.gradient.head(P) = -0.5 * grad.head(P);
  // dK/dlog(sigma^2) = sigma^2 I: -1/2 sigma^2 (alpha^T alpha - tr K^{-1}).
  out.gradient(P) = -0.5 * noise * (alpha.squaredNorm() - grad(P));
  MPI_Bcast(out.gradient.data(), P + 1, MPI_DOUBLE, 0, comm_);
  return out;
}

}  // namespace gipdyn
