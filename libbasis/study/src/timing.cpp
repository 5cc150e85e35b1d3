#include "basis/study/timing.h"

#include <algorithm>
#include <chrono>

namespace basis {
namespace {

using Clock = std::chrono::steady_clock;

// Calls per clock reading: one for slow kernels, more for fast ones (the clock costs ~20 ns).
int calls_per_reading(const std::function<void()>& kernel) {
  const auto probe = Clock::now();
  kernel();
  return std::chrono::duration<double>(Clock::now() - probe).count() > 1e-6 ? 1 : 64;
}

// One run: `kernel` repeated in batches for about `seconds`; the time per call in nanoseconds.
double one_run_ns(const std::function<void()>& kernel, int batch, double seconds) {
  long long calls = 0;
  const auto start = Clock::now();
  double elapsed = 0;
  do {
    for (int k = 0; k < batch; ++k)
      kernel();
    calls += batch;
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  } while (elapsed < seconds);
  return elapsed * 1e9 / double(calls);
}

}  // namespace

RunTimes run_times_ns(const std::function<void()>& kernel, double seconds) {
  const int batch = calls_per_reading(kernel);
  RunTimes runs;
  for (double& run : runs)
    run = one_run_ns(kernel, batch, seconds);
  return runs;
}

double median_of(RunTimes values) {
  std::nth_element(values.begin(), values.begin() + 2, values.end());
  return values[2];
}

double median_time_ns(const std::function<void()>& kernel, double seconds) {
  return median_of(run_times_ns(kernel, seconds));
}

// Runs next to each other meet the same moment of the machine, so that their ratios move less
// than the times; swapping which comes first from one pair to the next leaves neither side the
// one that always follows the other (and inherits its state of the caches).
AlternatingRuns alternating_run_times_ns(const std::function<void()>& a,
                                         const std::function<void()>& b, double seconds) {
  const int batch_a = calls_per_reading(a), batch_b = calls_per_reading(b);
  AlternatingRuns runs;
  for (std::size_t run = 0; run < runs.a_ns.size(); ++run) {
    if (run % 2 == 0) {
      runs.a_ns[run] = one_run_ns(a, batch_a, seconds);
      runs.b_ns[run] = one_run_ns(b, batch_b, seconds);
    } else {
      runs.b_ns[run] = one_run_ns(b, batch_b, seconds);
      runs.a_ns[run] = one_run_ns(a, batch_a, seconds);
    }
  }
  return runs;
}

}  // namespace basis
