// Shards of a run over many points: shard I of N owns a contiguous range of the points, so that
// the shards' outputs, in order, are the whole run's.
#pragma once

#include <cstdint>
#include <string>

namespace basis {

// Points [first, first + count) of a run.
struct PointRange {
  std::uint64_t first = 0;
  std::uint64_t count = 0;

  std::uint64_t end() const { return first + count; }
  bool operator==(const PointRange&) const = default;
};

// Shard `index` of `count` (0 <= index < count).
struct Shard {
  int index = 0;
  int count = 1;

  bool operator==(const Shard&) const = default;
};

// Most shards a run is split into.
inline constexpr int kMaxShards = 1 << 20;

// The points shard s owns of a run of `total` points: [floor(s.index total / s.count),
// floor((s.index + 1) total / s.count)), so that sizes differ by at most one and the ranges of
// shards 0 .. count - 1 tile [0, total) in order. Throws std::invalid_argument for a shard
// outside 0 <= index < count <= kMaxShards.
PointRange shard_range(std::uint64_t total, const Shard& shard);

// Reads "I/N" (I from 0); throws std::invalid_argument naming the text for anything else.
Shard parse_shard(const std::string& text);

}  // namespace basis
