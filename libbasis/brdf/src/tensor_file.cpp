#include "tensor_file.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

namespace basis::rgl {

namespace {

// The tensor_file container: a little-endian header of named n-dimensional arrays.

constexpr char kMagic[12] = {'t', 'e', 'n', 's', 'o', 'r', '_', 'f', 'i', 'l', 'e', '\0'};
constexpr std::size_t kHeaderSize = 18;         // magic, two version bytes, uint32 field count
constexpr std::size_t kMinDescriptorSize = 13;  // name length, ndim, dtype, offset
constexpr std::size_t kMaxDimensions = 8;       // the format's fields have at most 5

struct Dtype {
  const char* name;
  std::size_t bytes;
};
// Indexed by the file's dtype code; code 0 is invalid.
constexpr std::array<Dtype, 12> kDtypes = {{{"invalid", 0},
                                            {"uint8", 1},
                                            {"int8", 1},
                                            {"uint16", 2},
                                            {"int16", 2},
                                            {"uint32", 4},
                                            {"int32", 4},
                                            {"uint64", 8},
                                            {"int64", 8},
                                            {"float16", 2},
                                            {"float32", 4},
                                            {"float64", 8}}};

// Unsigned little-endian integer of n bytes at p.
std::uint64_t load_le(const unsigned char* p, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t k = n; k-- > 0;)
    v = (v << 8) | p[k];
  return v;
}

}  // namespace

std::string shape_text(const std::vector<std::uint64_t>& shape) {
  std::string s = "[";
  for (std::size_t k = 0; k < shape.size(); ++k)
    s += (k ? " x " : "") + std::to_string(shape[k]);
  return s + "]";
}

const Field& TensorFile::get(const std::string& name, int dtype, std::size_t ndim) const {
  const auto it = fields_.find(name);
  if (it == fields_.end()) fail("missing field '" + name + "'");
  const Field& f = it->second;
  if (f.dtype != dtype || f.shape.size() != ndim)
    fail("field '" + name + "' must be a " + std::to_string(ndim) + "-D " +
         kDtypes[std::size_t(dtype)].name + " array, got a " + std::to_string(f.shape.size()) +
         "-D " + kDtypes[std::size_t(f.dtype)].name + " array of shape " + shape_text(f.shape));
  return f;
}

std::vector<double> TensorFile::floats(const Field& f) const {
  std::vector<double> values(std::size_t(f.count));
  const unsigned char* p = bytes_.data() + f.offset;
  for (std::size_t k = 0; k < values.size(); ++k) {
    const auto bits = std::uint32_t(load_le(p + 4 * k, 4));
    values[k] = double(std::bit_cast<float>(bits));
    if (!std::isfinite(values[k])) fail("field '" + f.name + "' holds NaN or infinity");
  }
  return values;
}

std::vector<unsigned char> TensorFile::octets(const Field& f) const {
  const auto* p = bytes_.data() + f.offset;
  return std::vector<unsigned char>(p, p + f.count);
}

void TensorFile::parse_header() {
  const std::size_t size = bytes_.size();
  if (size == 0) fail("empty file");
  if (size >= sizeof kMagic && std::memcmp(bytes_.data(), kMagic, sizeof kMagic) != 0)
    fail("not a tensor_file (the first 12 bytes are not \"tensor_file\\0\")");
  if (size < kHeaderSize)
    fail("too short for a tensor_file header (" + std::to_string(size) + " of " +
         std::to_string(kHeaderSize) + " bytes)");
  if (bytes_[12] != 1 || bytes_[13] != 0)
    fail("unsupported tensor_file version " + std::to_string(bytes_[12]) + "." +
         std::to_string(bytes_[13]) + " (expected 1.0)");
  const std::uint64_t n_fields = load_le(&bytes_[14], 4);
  if (n_fields > (size - kHeaderSize) / kMinDescriptorSize)
    fail("header declares " + std::to_string(n_fields) + " fields, more than its " +
         std::to_string(size) + " bytes can hold");

  std::size_t pos = kHeaderSize;
  auto take = [&](std::size_t n, std::uint64_t index) -> const unsigned char* {
    if (n > size - pos)
      fail("truncated header (field descriptor " + std::to_string(index + 1) + " of " +
           std::to_string(n_fields) + " ends past the end of the file)");
    const unsigned char* p = bytes_.data() + pos;
    pos += n;
    return p;
  };
  for (std::uint64_t index = 0; index < n_fields; ++index) {
    Field f;
    const auto name_length = std::size_t(load_le(take(2, index), 2));
    const unsigned char* name = take(name_length, index);
    f.name.assign(reinterpret_cast<const char*>(name), name_length);
    const auto ndim = std::size_t(load_le(take(2, index), 2));
    f.dtype = *take(1, index);
    f.offset = load_le(take(8, index), 8);
    if (ndim > kMaxDimensions)
      fail("field '" + f.name + "' has " + std::to_string(ndim) + " dimensions (at most " +
           std::to_string(kMaxDimensions) + " are supported)");
    if (f.dtype < 1 || f.dtype >= int(kDtypes.size()))
      fail("field '" + f.name + "' has invalid dtype code " + std::to_string(f.dtype));
    const unsigned char* dims = take(8 * ndim, index);
    for (std::size_t k = 0; k < ndim; ++k)
      f.shape.push_back(load_le(dims + 8 * k, 8));

    std::uint64_t n_bytes = kDtypes[std::size_t(f.dtype)].bytes;
    bool overflow = false;
    for (std::uint64_t d : f.shape) {
      if (d != 0 && f.count > std::numeric_limits<std::uint64_t>::max() / d) overflow = true;
      f.count = overflow ? 0 : f.count * d;
    }
    if (!overflow && f.count > std::numeric_limits<std::uint64_t>::max() / n_bytes) overflow = true;
    if (overflow)
      fail("field '" + f.name + "' has an impossibly large shape " + shape_text(f.shape));
    n_bytes *= f.count;
    if (n_bytes > size || f.offset > size - n_bytes)
      fail("field '" + f.name + "' data (" + std::to_string(n_bytes) + " bytes at offset " +
           std::to_string(f.offset) + ") lies outside the file (" + std::to_string(size) +
           " bytes)");
    const std::string key = f.name;
    if (!fields_.emplace(key, std::move(f)).second)
      fail("field '" + key + "' appears twice in the header");
  }
}

}  // namespace basis::rgl
