// Timing of two kernels in pairs of runs: the order of the runs, and which side each time
// belongs to.
#include "basis/study/timing.h"

#include <gtest/gtest.h>

#include <chrono>
#include <string>

namespace basis {
namespace {

// Busy for at least `seconds` of the steady clock.
void busy_for(double seconds) {
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() <
         seconds) {
  }
}

TEST(Timing, PairsOfRunsSwapWhichSideComesFirst) {
  // Kernels slower than a clock reading are called once per batch, and a run of 0 seconds is
  // one batch: each run is one call, after one probing call of each side.
  std::string calls;
  const auto a = [&calls] {
    calls += 'a';
    busy_for(2e-6);
  };
  const auto b = [&calls] {
    calls += 'b';
    busy_for(2e-6);
  };
  alternating_run_times_ns(a, b, 0);
  // The probes (a, b), then the pairs: a b, b a, a b, b a, a b.
  EXPECT_EQ(calls, "ababbaabbaab");
}

TEST(Timing, EachSideKeepsItsOwnTimes) {
  // a takes at least 20 microseconds, b at least 2 milliseconds: whichever comes first in a
  // pair, each of a's times is at least 20 microseconds and each of b's at least 2 ms.
  const AlternatingRuns runs =
      alternating_run_times_ns([] { busy_for(2e-5); }, [] { busy_for(2e-3); }, 0);
  for (const double ns : runs.a_ns)
    EXPECT_GE(ns, 2e4);
  for (const double ns : runs.b_ns)
    EXPECT_GE(ns, 2e6);
}

TEST(Timing, MedianOfFiveIsTheMiddleValue) {
  EXPECT_EQ(median_of({5, 1, 4, 2, 3}), 3);
  EXPECT_EQ(median_of({7, 7, 1, 9, 9}), 7);
}

}  // namespace
}  // namespace basis
