// The control-loop promise: after a PredictionWorkspace is built, single-query
// prediction makes no heap allocation. This binary interposes malloc and
// friends (glibc's __libc_* entry points) and counts calls while armed.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "gipdyn/model/training.hpp"
#include "test_util.hpp"

extern "C" {
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void* __libc_memalign(size_t, size_t);
void __libc_free(void*);
}

namespace {
std::atomic<bool> g_armed{false};
std::atomic<long> g_allocations{0};
void note() {
  if (g_armed.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(size_t n) {
  note();
  return __libc_malloc(n);
}
void* calloc(size_t a, size_t b) {
  note();
  return __libc_calloc(a, b);
}
void* realloc(void* p, size_t n) {
  note();
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
int posix_memalign(void** out, size_t align, size_t n) {
  note();
  *out = __libc_memalign(align, n);
  return *out ? 0 : 12;
}
void* aligned_alloc(size_t align, size_t n) {
  note();
  return __libc_memalign(align, n);
}
void* memalign(size_t align, size_t n) {
  note();
  return __libc_memalign(align, n);
}
}

namespace gipdyn {
namespace {

TEST(NoAllocation, InterpositionSeesAllocations) {
  static void* volatile sink_c;  // volatile: the compiler may not elide the pairs
  static double* volatile sink_cpp;
  g_allocations = 0;
  g_armed = true;
  sink_c = std::malloc(64);
  sink_cpp = new double[8];
  g_armed = false;
  std::free(sink_c);
  delete[] sink_cpp;
  EXPECT_GE(g_allocations.load(), 2);  // the counter works, so a zero below means something
}

TEST(NoAllocation, SingleQueryPredictionDoesNotAllocate) {
  for (const char* kernel : {"gip", "gip-friction", "rbf"}) {
    const JointTypes joints = JointTypes::parse("RRPR");
    const Eigen::MatrixXd X = test::random_inputs(joints, 80, 61);
    const Eigen::MatrixXd Y = Eigen::MatrixXd::Random(80, 4);
    TrainOptions o;
    o.kernel = kernel;
    o.optimizer.max_iterations = 5;
    TrainResult r = train_model(X, Y, joints, o);
    ASSERT_TRUE(r.report.ok()) << r.report.message;
    PredictionWorkspace ws(r.model);
    const Eigen::MatrixXd Xq = test::random_inputs(joints, 10, 62);
    Eigen::VectorXd x(12), tau(4), sd(4);
    ws.predict(Xq.row(0).transpose().eval().data(), tau.data(), sd.data());  // warm-up of the variance path
    g_allocations = 0;
    g_armed = true;
    for (int k = 0; k < 10; ++k) {
      for (int c = 0; c < 12; ++c) x(c) = Xq(k, c);
      ws.predict(x.data(), tau.data());
      ws.predict(x.data(), tau.data(), sd.data());
    }
    g_armed = false;
    EXPECT_EQ(g_allocations.load(), 0) << kernel;
  }
}

}  // namespace
}  // namespace gipdyn
