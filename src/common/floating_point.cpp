#include "gipdyn/floating_point.hpp"

#if defined(__x86_64__) || defined(__SSE2__)
#include <xmmintrin.h>

namespace gipdyn {

namespace {
constexpr unsigned kFlushToZeroAndDenormalsAreZero = 0x8040u;  // MXCSR bits FTZ (15) and DAZ (6)
}

FlushSubnormalsToZero::FlushSubnormalsToZero() : saved_mode_(_mm_getcsr()) {
  _mm_setcsr(saved_mode_ | kFlushToZeroAndDenormalsAreZero);
}
FlushSubnormalsToZero::~FlushSubnormalsToZero() { _mm_setcsr(saved_mode_); }

}  // namespace gipdyn

#else

namespace gipdyn {
FlushSubnormalsToZero::FlushSubnormalsToZero() = default;
FlushSubnormalsToZero::~FlushSubnormalsToZero() = default;
}  // namespace gipdyn

#endif
