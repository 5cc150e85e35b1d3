// Shards of a run: the ranges of shards 0 .. N - 1 tile the points in order, with sizes that
// differ by at most one, for totals up to 2^63 (checked against 128-bit arithmetic).
#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>

#include "basis/core/shard.h"

namespace basis {
namespace {

__extension__ typedef unsigned __int128 Wide;

// floor(total index / count) in 128 bits: the definition, computed another way.
std::uint64_t reference_start(std::uint64_t total, int index, int count) {
  return std::uint64_t(Wide(total) * unsigned(index) / unsigned(count));
}

TEST(ShardRange, ShardsTileTheRunInOrder) {
  const std::uint64_t totals[] = {1,     2,          3,          7,          10,
                                  1000,  1000003,    4294967311, 1ull << 40, (1ull << 63) + 12345,
                                  99991, 1ull << 20, 123456789};
  const int counts[] = {1, 2, 3, 4, 7, 8, 16, 1000, 1 << 20};
  for (const std::uint64_t total : totals)
    for (const int count : counts) {
      if (std::uint64_t(count) > total) continue;
      std::uint64_t next = 0, smallest = UINT64_MAX, largest = 0;
      const int step = count > 4096 ? count / 997 : 1;  // every shard of small splits
      for (int i = 0; i < count; i += step) {
        const PointRange r = shard_range(total, {i, count});
        EXPECT_EQ(r.first, reference_start(total, i, count)) << total << " " << i << "/" << count;
        EXPECT_EQ(r.end(), reference_start(total, i + 1, count));
        if (step == 1) {
          EXPECT_EQ(r.first, next);
          next = r.end();
        }
        EXPECT_GE(r.count, total / std::uint64_t(count));
        smallest = std::min(smallest, r.count);
        largest = std::max(largest, r.count);
      }
      if (step == 1) {
        EXPECT_EQ(next, total) << total << " " << count;
      }
      EXPECT_LE(largest - smallest, 1u);
      EXPECT_GE(smallest, 1u);
    }
}

TEST(ShardRange, RefusesShardsNoRunHas) {
  EXPECT_THROW(shard_range(10, {0, 0}), std::invalid_argument);
  EXPECT_THROW(shard_range(10, {3, 3}), std::invalid_argument);
  EXPECT_THROW(shard_range(10, {-1, 3}), std::invalid_argument);
  EXPECT_THROW(shard_range(10, {0, kMaxShards + 1}), std::invalid_argument);
}

TEST(ParseShard, ReadsIOfNAndNothingElse) {
  EXPECT_EQ(parse_shard("0/1"), (Shard{0, 1}));
  EXPECT_EQ(parse_shard("3/4"), (Shard{3, 4}));
  EXPECT_EQ(parse_shard("1023/1024"), (Shard{1023, 1024}));
  for (const char* bad : {"", "3", "4/4", "-1/4", "1/0", "1/4x", " 1/4", "1 /4", "a/b", "1/", "/4",
                          "1/4/5", "99999999999/2", "0/2000000"})
    EXPECT_THROW(parse_shard(bad), std::invalid_argument) << bad;
}

}  // namespace
}  // namespace basis
