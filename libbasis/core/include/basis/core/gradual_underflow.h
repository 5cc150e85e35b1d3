// The floating-point modes the certified bounds assume: gradual underflow, subnormals neither
// flushed to zero nor read as zero. A program may run with flush-to-zero and
// denormals-are-zero set (renderers often do, and ray tracers ask for them); the library's
// certified computations clear both in this thread while a scope lasts, then give the caller its
// modes back. On x86 (SSE2); elsewhere the scope changes nothing.
#pragma once

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace basis {

class GradualUnderflow {
 public:
#if defined(__SSE2__)
  // Reading the modes is cheap; they are written only when the caller had either set.
  GradualUnderflow() : saved_(_mm_getcsr() & kModes) {
    if (saved_ != 0) _mm_setcsr(_mm_getcsr() & ~kModes);
  }
  ~GradualUnderflow() {
    if (saved_ != 0) _mm_setcsr((_mm_getcsr() & ~kModes) | saved_);
  }
#else
  GradualUnderflow() {}
  ~GradualUnderflow() {}
#endif
  GradualUnderflow(const GradualUnderflow&) = delete;
  GradualUnderflow& operator=(const GradualUnderflow&) = delete;

 private:
#if defined(__SSE2__)
  static constexpr unsigned kModes = _MM_FLUSH_ZERO_MASK | _MM_DENORMALS_ZERO_MASK;
  unsigned saved_ = 0;
#endif
};

}  // namespace basis
