#include "gipdyn/floating_point.hpp"

#if defined(__x86_64__) || defined(__SSE2__)
#include <xmmintrin.h>
#define GIPDYN_HAVE_MXCSR 1
#endif

namespace gipdyn {

namespace {
constexpr unsigned kFlushToZeroAndDenormalsAreZero = 0x8040u;
}

#ifdef GIPDYN_HAVE_MXCSR
FlushSubnormalsToZero::FlushSubnormalsToZero() : saved_mode_(_mm_getcsr()) {
  _mm_setcsr(saved_mode_ | kFlushToZeroAndDenormalsAreZero);
}
FlushSubnormalsToZero::~FlushSubnormalsToZero() { _mm_setcsr(saved_mode_); }
#else
FlushSubnormalsToZero::FlushSubnormalsToZero() { (void)kFlushToZeroAndDenormalsAreZero; }
FlushSubnormalsToZero::~FlushSubnormalsToZero() = default;
#endif

}  // namespace gipdyn
