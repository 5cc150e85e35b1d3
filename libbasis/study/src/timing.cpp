#include "basis/study/timing.h"

#include <algorithm>
#include <chrono>
#include <vector>

namespace basis {

double median_time_ns(const std::function<void()>& kernel, double seconds) {
  // Calls per clock reading: one for slow kernels, more for fast ones (the clock costs ~20 ns).
  auto now = [] { return std::chrono::steady_clock::now(); };
  const auto probe = now();
  kernel();
  const double first = std::chrono::duration<double>(now() - probe).count();
  const int batch = first > 1e-6 ? 1 : 64;
  std::vector<double> runs;
  for (int run = 0; run < 5; ++run) {
    long long calls = 0;
    const auto start = now();
    double elapsed = 0;
    do {
      for (int k = 0; k < batch; ++k)
        kernel();
      calls += batch;
      elapsed = std::chrono::duration<double>(now() - start).count();
    } while (elapsed < seconds);
    runs.push_back(elapsed * 1e9 / double(calls));
  }
  std::nth_element(runs.begin(), runs.begin() + 2, runs.end());
  return runs[2];
}

}  // namespace basis
