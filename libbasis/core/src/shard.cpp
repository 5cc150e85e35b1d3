#include "basis/core/shard.h"

#include <charconv>
#include <stdexcept>

namespace basis {

namespace {

void check(const Shard& shard) {
  if (shard.count < 1 || shard.count > kMaxShards || shard.index < 0 || shard.index >= shard.count)
    throw std::invalid_argument("shard " + std::to_string(shard.index) + "/" +
                                std::to_string(shard.count) +
                                ": needs 0 <= I < N <= " + std::to_string(kMaxShards));
}

// floor(a * b / c) without overflow for a < 2^64, b <= c <= 2^20.
std::uint64_t scaled(std::uint64_t total, std::uint64_t index, std::uint64_t count) {
  return total / count * index + total % count * index / count;
}

}  // namespace

PointRange shard_range(std::uint64_t total, const Shard& shard) {
  check(shard);
  const std::uint64_t first = scaled(total, std::uint64_t(shard.index), std::uint64_t(shard.count));
  const std::uint64_t end =
      scaled(total, std::uint64_t(shard.index) + 1, std::uint64_t(shard.count));
  return {first, end - first};
}

Shard parse_shard(const std::string& text) {
  Shard shard;
  const char* p = text.data();
  const char* end = p + text.size();
  auto [after_index, e1] = std::from_chars(p, end, shard.index);
  if (e1 != std::errc() || after_index == end || *after_index != '/')
    throw std::invalid_argument("expected I/N (shard I of N, I from 0), got '" + text + "'");
  auto [after_count, e2] = std::from_chars(after_index + 1, end, shard.count);
  if (e2 != std::errc() || after_count != end)
    throw std::invalid_argument("expected I/N (shard I of N, I from 0), got '" + text + "'");
  check(shard);
  return shard;
}

}  // namespace basis
