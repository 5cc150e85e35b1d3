// The tensor_file container of RGL-EPFL measured BRDFs (private to the RGL reader): a
// little-endian header of named n-dimensional arrays, checked field by field.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "basis/core/file_error.h"

namespace basis::rgl {

// Largest tensor_file read (checked before reading it).
inline constexpr std::uintmax_t kMaxFileSize = std::uintmax_t(1) << 30;

// Data type codes of the fields the reader takes.
constexpr int kUint8 = 1, kFloat32 = 10;

struct Field {
  std::string name;
  int dtype = 0;
  std::uint64_t offset = 0;
  std::vector<std::uint64_t> shape;
  std::uint64_t count = 1;  // product of the shape
};

// A parsed tensor_file held in memory; every problem becomes FileError "PATH: problem".
// A shape as text, "[3 x 4]", for errors.
std::string shape_text(const std::vector<std::uint64_t>& shape);

class TensorFile {
 public:
  TensorFile(std::string path, std::vector<unsigned char> bytes)
      : path_(std::move(path)), bytes_(std::move(bytes)) {
    parse_header();
  }

  [[noreturn]] void fail(const std::string& problem) const {
    throw FileError(path_ + ": " + problem);
  }

  bool has(const std::string& name) const { return fields_.count(name) != 0; }

  // The field called name, which must exist with this dtype and number of dimensions.
  const Field& get(const std::string& name, int dtype, std::size_t ndim) const;

  // A float32 field's values as doubles; all must be finite.
  std::vector<double> floats(const Field& f) const;

  // A uint8 field's bytes.
  std::vector<unsigned char> octets(const Field& f) const;

 private:
  void parse_header();

  std::string path_;
  std::vector<unsigned char> bytes_;
  std::map<std::string, Field> fields_;
};

}  // namespace basis::rgl
