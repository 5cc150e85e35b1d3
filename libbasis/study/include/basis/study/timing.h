// Timing of short kernels for studies and tools: medians of repeated runs on one thread.
#pragma once

#include <array>
#include <functional>

namespace basis {

// Five runs' times.
using RunTimes = std::array<double, 5>;

// The time per call of `kernel` in five runs, each repeating it for about `seconds`, in
// nanoseconds.
RunTimes run_times_ns(const std::function<void()>& kernel, double seconds);

// The median of five values.
double median_of(RunTimes values);

// Median over five runs of the time per call of `kernel`, each run repeating it for about
// `seconds`, in nanoseconds.
double median_time_ns(const std::function<void()>& kernel, double seconds);

// The times per call of kernels a and b in five runs each, taken in pairs, the order swapped
// from one pair to the next (a b, b a, a b, b a, a b), each run repeating its kernel for about
// `seconds`, in nanoseconds. Run k of a and run k of b form pair k.
struct AlternatingRuns {
  RunTimes a_ns{}, b_ns{};
};
AlternatingRuns alternating_run_times_ns(const std::function<void()>& a,
                                         const std::function<void()>& b, double seconds);

}  // namespace basis
