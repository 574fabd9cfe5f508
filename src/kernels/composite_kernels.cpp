#include "gipdyn/kernels/composite_kernels.hpp"

#include <cmath>
#include <cstdint>
#include <deque>

#include "gipdyn/error.hpp"
#include "gipdyn/kernels/linear_kernel.hpp"

namespace gipdyn {

namespace {

// A composite's buffers for its further children at its own nesting level (a
// product inside a sum has the levels below its sum's), held for one scope: the
// children it calls take the next levels, and leaving the scope, even by an
// exception, hands the levels back. One level unless a composite needs several
// buffers at once (operator[]); a deque keeps them in place when a deeper level
// is added. Sized by the caller once: a control-loop query, and an optimiser's
// next evaluation, then allocate nothing.
template <class Buffer>
class LevelBuffer {
 public:
  LevelBuffer(std::deque<Buffer>& buffers, size_t& level, size_t count = 1)
      : buffers_(buffers), level_(level), first_(level), count_(count) {
    if (buffers.size() < level + count) buffers.resize(level + count);
    level_ += count;
  }
  ~LevelBuffer() { level_ -= count_; }
  LevelBuffer(const LevelBuffer&) = delete;
  LevelBuffer& operator=(const LevelBuffer&) = delete;
  Buffer& operator*() const { return buffers_[first_]; }
  Buffer& operator[](size_t i) const { return buffers_[first_ + i]; }
  size_t first() const { return first_; }

 private:
  std::deque<Buffer>& buffers_;
  size_t& level_;
  size_t first_, count_;
};

using GramTag = KernelScratch::GramTag;

// FNV-1a over Z's bytes: a Gram tag's check that the rows are the same ones.
std::uint64_t content_hash(const Eigen::MatrixXd& Z) {
  std::uint64_t h = 1469598103934665603ull;
  const auto* bytes = reinterpret_cast<const unsigned char*>(Z.data());
  for (Eigen::Index i = 0; i < Z.size() * static_cast<Eigen::Index>(sizeof(double)); ++i) {
    h ^= bytes[i];
    h *= 1099511628211ull;
  }
  return h;
}

// The tag of k(Z, Z) for `kernel` at its hyperparameters now; z_hash: content_hash(Z).
GramTag gram_tag(const Kernel& kernel, const Eigen::MatrixXd& Z, std::uint64_t z_hash) {
  GramTag t;
  t.kernel = kernel.instance();
  t.z = Z.data();
  t.rows = Z.rows();
  t.cols = Z.cols();
  t.z_hash = z_hash;
  t.log_params = kernel.log_params();
  return t;
}

bool same_gram(const GramTag& a, const GramTag& b) {
  return a.kernel != 0 && a.kernel == b.kernel && a.z == b.z && a.rows == b.rows && a.cols == b.cols &&
         a.z_hash == b.z_hash && a.log_params.size() == b.log_params.size() &&
         (a.log_params.array() == b.log_params.array()).all();
}

// A level's N x N buffers of scratch.child_grams with their tags. Written for
// something other than a child's Gram (keep_tags false), their tags are
// cleared on entry; a product's contraction keeps them, to find the Gram
// matrices its gram_lower left.
class GramSlots {
 public:
  GramSlots(KernelScratch& scratch, size_t count, bool keep_tags)
      : buffers_(scratch.child_grams, scratch.gram_level, count), tags_(scratch.child_gram_tags) {
    const size_t end = buffers_.first() + count;
    if (tags_.size() < end) tags_.resize(end);
    if (!keep_tags)
      for (size_t i = buffers_.first(); i < end; ++i) tags_[i] = GramTag{};
  }
  Eigen::MatrixXd& operator[](size_t i) const { return buffers_[i]; }
  GramTag& tag(size_t i) const { return tags_[buffers_.first() + i]; }

 private:
  LevelBuffer<Eigen::MatrixXd> buffers_;
  std::deque<GramTag>& tags_;
};

}  // namespace

CompositeKernel::CompositeKernel(std::vector<std::unique_ptr<Kernel>> children) : children_(std::move(children)) {
  if (children_.empty()) throw Error("a composite kernel needs at least one child kernel");
}

CompositeKernel::CompositeKernel(const CompositeKernel& other) : Kernel(other) {
  for (const auto& c : other.children_) children_.push_back(c->clone());
}

int CompositeKernel::num_params() const {
  int n = 0;
  for (const auto& c : children_) n += c->num_params();
  return n;
}

std::vector<std::string> CompositeKernel::param_names() const {
  std::vector<std::string> names;
  for (const auto& c : children_) {
    auto sub = c->param_names();
    names.insert(names.end(), sub.begin(), sub.end());
  }
  return names;
}

Eigen::VectorXd CompositeKernel::log_params() const {
  Eigen::VectorXd p(num_params());
  int o = 0;
  for (const auto& c : children_) {
    p.segment(o, c->num_params()) = c->log_params();
    o += c->num_params();
  }
  return p;
}

void CompositeKernel::set_log_params(const Eigen::Ref<const Eigen::VectorXd>& p) {
  if (p.size() != num_params()) throw Error("composite kernel: wrong number of parameters");
  int o = 0;
  for (auto& c : children_) {
    c->set_log_params(p.segment(o, c->num_params()));
    o += c->num_params();
  }
}

void CompositeKernel::restrict_log_params(const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> lower,
                                          Eigen::Ref<Eigen::VectorXd> upper) const {
  for (int c = 0; c < num_children(); ++c) {
    const int count = children_[static_cast<size_t>(c)]->num_params();
    children_[static_cast<size_t>(c)]->restrict_log_params(Z, lower.segment(offset(c), count),
                                                           upper.segment(offset(c), count));
  }
}

int CompositeKernel::offset(int child) const {
  int o = 0;
  for (int c = 0; c < child; ++c) o += children_[static_cast<size_t>(c)]->num_params();
  return o;
}

std::pair<int, int> CompositeKernel::locate(int p) const {
  for (int c = 0; c < num_children(); ++c) {
    const int n = children_[static_cast<size_t>(c)]->num_params();
    if (p < n) return {c, p};
    p -= n;
  }
  throw Error("composite kernel: parameter index out of range");
}

void ProductKernel::cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const {
  children_[0]->cross(Z1, Z2, K);
  Eigen::MatrixXd Kc;
  for (size_t c = 1; c < children_.size(); ++c) {
    children_[c]->cross(Z1, Z2, Kc);
    K.array() *= Kc.array();
  }
}

void ProductKernel::gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& scratch) const {
  // The same products as cross(), so fits do not change: the children's
  // lower-triangle paths round differently and were no faster (1000 rows,
  // the real preset's kernel). Each child's matrix stays in its tagged slot
  // for the contraction of the same evaluation (contract_product).
  const size_t n = children_.size();
  GramSlots slots(scratch, n, false);
  const std::uint64_t z_hash = content_hash(Z);
  for (size_t c = 0; c < n; ++c) {
    children_[c]->cross(Z, Z, slots[c]);
    slots.tag(c) = gram_tag(*children_[c], Z, z_hash);
  }
  K = slots[0];
  for (size_t c = 1; c < n; ++c) K.array() *= slots[c].array();
}

void ProductKernel::diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const {
  children_[0]->diagonal(Z, d);
  Eigen::VectorXd dc;
  for (size_t c = 1; c < children_.size(); ++c) {
    children_[c]->diagonal(Z, dc);
    d.array() *= dc.array();
  }
}

void ProductKernel::gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p,
                                    Eigen::MatrixXd& dK) const {
  const auto [owner, local] = locate(p);
  children_[static_cast<size_t>(owner)]->gradient_matrix(Z1, Z2, local, dK);
  Eigen::MatrixXd Kc;
  for (int c = 0; c < num_children(); ++c) {
    if (c == owner) continue;
    children_[static_cast<size_t>(c)]->cross(Z1, Z2, Kc);
    dK.array() *= Kc.array();
  }
}

// sum_ij W_ij (dK_c)_ij prod_{c' != c} (K_c')_ij: each child c contracts W o R_c,
// with R_c the product of the other children's k(Z1, Z2).
// The children's matrices and W o R_c live in the scratch's buffers, so that
// an optimiser's evaluations reuse them instead of allocating (and paging in)
// n + 1 fresh N x N matrices each time. For k(Z, Z), a child's matrix that
// gram_lower left in its slot, for the same hyperparameters and rows, is used
// as it is; contract_child gets it too.
template <class ContractChild>
void contract_product(const std::vector<std::unique_ptr<Kernel>>& children, const Eigen::MatrixXd& Z1,
                      const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W, KernelScratch& scratch,
                      ContractChild&& contract_child) {
  const size_t n = children.size();
  GramSlots slots(scratch, n + 1, true);
  const bool gram = &Z1 == &Z2;
  const std::uint64_t z_hash = gram ? content_hash(Z1) : 0;
  for (size_t c = 0; c < n; ++c) {
    if (gram) {
      GramTag tag = gram_tag(*children[c], Z1, z_hash);
      if (same_gram(slots.tag(c), tag)) continue;
      children[c]->cross(Z1, Z2, slots[c]);
      slots.tag(c) = std::move(tag);
    } else {
      children[c]->cross(Z1, Z2, slots[c]);
      slots.tag(c) = GramTag{};
    }
  }
  Eigen::MatrixXd& WR = slots[n];
  slots.tag(n) = GramTag{};
  for (size_t c = 0; c < n; ++c) {
    WR = W;
    for (size_t o = 0; o < n; ++o)
      if (o != c) WR.array() *= slots[o].array();
    contract_child(c, WR, slots[c]);
  }
}

void ProductKernel::contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                             KernelScratch& scratch) const {
  contract_product(children_, Z, Z, W, scratch, [&](size_t c, const Eigen::MatrixXd& WR, const Eigen::MatrixXd& Kc) {
    children_[c]->contract_with_gram(Z, WR, Kc, grad.segment(offset(static_cast<int>(c)), children_[c]->num_params()),
                                     scratch);
  });
}

void ProductKernel::contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                                   Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  contract_product(children_, Z1, Z2, W, scratch, [&](size_t c, const Eigen::MatrixXd& WR, const Eigen::MatrixXd&) {
    children_[c]->contract_cross(Z1, Z2, WR, grad.segment(offset(static_cast<int>(c)), children_[c]->num_params()),
                                 scratch);
  });
}

namespace {
std::vector<std::unique_ptr<Kernel>> pair_of(std::unique_ptr<Kernel> a, std::unique_ptr<Kernel> b) {
  std::vector<std::unique_ptr<Kernel>> v;
  v.push_back(std::move(a));
  v.push_back(std::move(b));
  return v;
}
}  // namespace

EnvelopeKernel::EnvelopeKernel(std::unique_ptr<Kernel> structured, std::unique_ptr<Kernel> envelope_rbf)
    : ProductKernel(pair_of(std::move(structured), std::move(envelope_rbf))) {}

void EnvelopeKernel::initialize(const Eigen::MatrixXd& Z, double target_variance) {
  children_[0]->initialize(Z, target_variance);
  children_[1]->initialize(Z, 1.0);
  // The RBF starts at one standard deviation per column; the envelope should vary slowly.
  Eigen::VectorXd p = children_[1]->log_params();
  p.tail(p.size() - 1).array() += std::log(kStartLengthscales);
  children_[1]->set_log_params(p);
}

namespace {

// The first child's row into out, each further child's combined into it by `combine(out, part)`.
template <class Combine>
void combine_child_rows(const std::vector<std::unique_ptr<Kernel>>& children, const double* z,
                        const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out, KernelScratch& scratch,
                        Combine&& combine) {
  children[0]->row(z, Z, out, scratch);
  LevelBuffer<Eigen::VectorXd> level(scratch.child_rows, scratch.child_level);
  Eigen::VectorXd& part = *level;
  part.resize(Z.rows());
  for (size_t c = 1; c < children.size(); ++c) {
    children[c]->row(z, Z, part, scratch);
    combine(out, part);
  }
}

}  // namespace

void ProductKernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                        KernelScratch& scratch) const {
  combine_child_rows(children_, z, Z, out, scratch,
                     [](Eigen::Ref<Eigen::VectorXd> acc, const Eigen::VectorXd& part) { acc.array() *= part.array(); });
}

double ProductKernel::self(const double* z, int feature_dim, KernelScratch& scratch) const {
  double k = 1.0;
  for (const auto& c : children_) k *= c->self(z, feature_dim, scratch);
  return k;
}

void SumKernel::row(const double* z, const Eigen::MatrixXd& Z, Eigen::Ref<Eigen::VectorXd> out,
                    KernelScratch& scratch) const {
  combine_child_rows(children_, z, Z, out, scratch,
                     [](Eigen::Ref<Eigen::VectorXd> acc, const Eigen::VectorXd& part) { acc += part; });
}

void SumKernel::plan_mean(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, MeanPlan& plan) const {
  plan = MeanPlan{};
  plan.parts.resize(children_.size());
  for (size_t c = 0; c < children_.size(); ++c) children_[c]->plan_mean(Z, alpha, plan.parts[c]);
}

double SumKernel::mean_one(const double* z, const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha,
                           const MeanPlan& plan, Eigen::Ref<Eigen::VectorXd> krow, KernelScratch& scratch) const {
  if (plan.parts.size() != children_.size()) return Kernel::mean_one(z, Z, alpha, plan, krow, scratch);
  double mean = 0.0;
  for (size_t c = 0; c < children_.size(); ++c) mean += children_[c]->mean_one(z, Z, alpha, plan.parts[c], krow, scratch);
  return mean;
}

double SumKernel::self(const double* z, int feature_dim, KernelScratch& scratch) const {
  double k = 0.0;
  for (const auto& c : children_) k += c->self(z, feature_dim, scratch);
  return k;
}

SumKernel::SumKernel(std::vector<std::unique_ptr<Kernel>> children, std::vector<double> shares)
    : CompositeKernel(std::move(children)), shares_(std::move(shares)) {
  if (shares_.size() != children_.size()) throw Error("sum kernel: one initial share per child is needed");
  for (double s : shares_)
    if (!(s > 0.0)) throw Error("sum kernel: initial shares must be positive");
}

void SumKernel::initialize(const Eigen::MatrixXd& Z, double target_variance) {
  for (size_t c = 0; c < children_.size(); ++c) {
    const double share = shares_.empty() ? 1.0 / static_cast<double>(children_.size()) : shares_[c];
    children_[c]->initialize(Z, share * target_variance);
  }
}

void SumKernel::cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, Eigen::MatrixXd& K) const {
  children_[0]->cross(Z1, Z2, K);
  Eigen::MatrixXd Kc;
  for (size_t c = 1; c < children_.size(); ++c) {
    children_[c]->cross(Z1, Z2, Kc);
    K += Kc;
  }
}

void SumKernel::diagonal(const Eigen::MatrixXd& Z, Eigen::VectorXd& d) const {
  children_[0]->diagonal(Z, d);
  Eigen::VectorXd dc;
  for (size_t c = 1; c < children_.size(); ++c) {
    children_[c]->diagonal(Z, dc);
    d += dc;
  }
}

void SumKernel::gradient_matrix(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, int p,
                                Eigen::MatrixXd& dK) const {
  const auto [owner, local] = locate(p);
  children_[static_cast<size_t>(owner)]->gradient_matrix(Z1, Z2, local, dK);
}

void SumKernel::contract(const Eigen::MatrixXd& Z, const Eigen::MatrixXd& W, Eigen::Ref<Eigen::VectorXd> grad,
                         KernelScratch& scratch) const {
  const GramSlots level(scratch, 1, true);  // the children one level below, as in gram_lower
  for (size_t c = 0; c < children_.size(); ++c)
    children_[c]->contract(Z, W, grad.segment(offset(static_cast<int>(c)), children_[c]->num_params()), scratch);
}

void SumKernel::contract_cross(const Eigen::MatrixXd& Z1, const Eigen::MatrixXd& Z2, const Eigen::MatrixXd& W,
                               Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  for (size_t c = 0; c < children_.size(); ++c)
    children_[c]->contract_cross(Z1, Z2, W, grad.segment(offset(static_cast<int>(c)), children_[c]->num_params()),
                                 scratch);
}

void SumKernel::gram_lower(const Eigen::MatrixXd& Z, Eigen::MatrixXd& K, KernelScratch& scratch) const {
  // Each child may use the scratch's other buffers, so the running sum lives
  // in K and each further child's matrix in this level's own buffer. The
  // children run one level below it, as in contract() and contract_nll(), so
  // that a product child finds the Gram matrices it left there.
  GramSlots level(scratch, 1, false);
  Eigen::MatrixXd& Kc = level[0];
  children_[0]->gram_lower(Z, K, scratch);
  for (size_t c = 1; c < children_.size(); ++c) {
    children_[c]->gram_lower(Z, Kc, scratch);
    K.triangularView<Eigen::Lower>() += Kc;
  }
}

void SumKernel::contract_nll(const Eigen::MatrixXd& Z, const Eigen::VectorXd& alpha, const Eigen::MatrixXd& Kinv_lower,
                             Eigen::Ref<Eigen::VectorXd> grad, KernelScratch& scratch) const {
  // W is shared by the children of a sum. A fused child reads alpha and Kinv
  // directly; the others share one W, built after the fused ones, which may use
  // the scratch's buffers, so a sum builds one N x N matrix for all of them.
  const auto segment = [&](size_t c) {
    return grad.segment(offset(static_cast<int>(c)), children_[c]->num_params());
  };
  const GramSlots level(scratch, 1, true);  // the children one level below, as in gram_lower
  bool needs_w = false;
  for (size_t c = 0; c < children_.size(); ++c) {
    if (children_[c]->fuses_nll_contraction())
      children_[c]->contract_nll(Z, alpha, Kinv_lower, segment(c), scratch);
    else
      needs_w = true;
  }
  if (!needs_w) return;
  nll_weights(alpha, Kinv_lower, scratch.c);
  for (size_t c = 0; c < children_.size(); ++c)
    if (!children_[c]->fuses_nll_contraction()) children_[c]->contract(Z, scratch.c, segment(c), scratch);
}

std::unique_ptr<ProductKernel> make_mpk(const std::vector<int>& columns, int degree, const std::string& prefix,
                                        const std::vector<std::string>& weight_labels) {
  if (degree < 1) throw Error("MPK degree must be at least 1");
  std::vector<std::unique_ptr<Kernel>> factors;
  for (int s = 1; s <= degree; ++s)
    factors.push_back(std::make_unique<LinearKernel>(columns, true, prefix + ".factor" + std::to_string(s), weight_labels));
  return std::make_unique<ProductKernel>(std::move(factors));
}

}  // namespace gipdyn
