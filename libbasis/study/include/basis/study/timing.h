// Timing of short kernels for studies and tools: medians of repeated runs on one thread.
#pragma once

#include <functional>

namespace basis {

// Median over five runs of the time per call of `kernel`, each run repeating it for about
// `seconds`, in nanoseconds.
double median_time_ns(const std::function<void()>& kernel, double seconds);

}  // namespace basis
