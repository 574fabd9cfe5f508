#pragma once
// Kernel values such as exp(-0.5 d^2) underflow when a lengthscale is tiny,
// as on real logs (docs/results/training.md), and x86 arithmetic that produces or reads
// subnormal numbers is many times slower than normal arithmetic. Values below
// 2.2e-308 change no NLL and no torque, so gipdyn's training threads and its
// prediction calls flush them to zero for their duration and then restore the
// caller's floating-point mode.

namespace gipdyn {

// While alive, the calling thread flushes subnormal results and inputs to zero
// (x86 MXCSR FTZ and DAZ; a no-op elsewhere). Restores the previous mode on
// destruction, also during stack unwinding.
class FlushSubnormalsToZero {
 public:
  FlushSubnormalsToZero();
  ~FlushSubnormalsToZero();
  FlushSubnormalsToZero(const FlushSubnormalsToZero&) = delete;
  FlushSubnormalsToZero& operator=(const FlushSubnormalsToZero&) = delete;

 private:
  unsigned saved_mode_ = 0;
};

}  // namespace gipdyn
