#include "basis/io/checksum.h"

#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <vector>

#include "basis/core/file_error.h"
#include "basis/io/atomic_file.h"

namespace basis {

namespace {

constexpr std::size_t kDigits = 2 * sizeof(XXH128_canonical_t);

// An XXH3-128 state fed piece by piece.
class Xxh128 {
 public:
  Xxh128() : state_(XXH3_createState(), XXH3_freeState) {
    if (!state_ || XXH3_128bits_reset(state_.get()) != XXH_OK)
      throw std::runtime_error("cannot start an XXH3-128 checksum");
  }
  void update(const void* data, std::size_t size) {
    if (XXH3_128bits_update(state_.get(), data, size) != XXH_OK)
      throw std::runtime_error("XXH3-128 update failed");
  }
  std::array<std::byte, 16> canonical_bytes() const {
    XXH128_canonical_t canonical;
    XXH128_canonicalFromHash(&canonical, XXH3_128bits_digest(state_.get()));
    static_assert(sizeof(canonical.digest) == 16);
    std::array<std::byte, 16> bytes;
    std::memcpy(bytes.data(), canonical.digest, bytes.size());
    return bytes;
  }

 private:
  std::unique_ptr<XXH3_state_t, XXH_errorcode (*)(XXH3_state_t*)> state_;
};

// A checksum's canonical bytes as the lowercase hex digits xxh128sum prints.
std::string hex_of(const std::array<std::byte, 16>& bytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string text;
  for (const std::byte byte : bytes) {
    text += kHex[unsigned(byte) >> 4];
    text += kHex[unsigned(byte) & 15];
  }
  return text;
}

}  // namespace

bool is_checksum_text(const std::string& text) {
  return text.size() == kDigits && std::all_of(text.begin(), text.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
         });
}

std::string checksum_hex(std::span<const std::byte> bytes) {
  return hex_of(pieces_checksum_bytes({bytes}));
}

std::string pieces_checksum_hex(std::initializer_list<std::span<const std::byte>> pieces) {
  return hex_of(pieces_checksum_bytes(pieces));
}

std::array<std::byte, 16> pieces_checksum_bytes(
    std::initializer_list<std::span<const std::byte>> pieces) {
  Xxh128 hash;
  for (const std::span<const std::byte> piece : pieces)
    hash.update(piece.data(), piece.size());
  return hash.canonical_bytes();
}

std::string file_checksum_hex(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(path + ": cannot open: " + std::strerror(errno));
  Xxh128 hash;
  std::vector<char> buffer(std::size_t(1) << 20);
  while (in) {
    in.read(buffer.data(), std::streamsize(buffer.size()));
    hash.update(buffer.data(), std::size_t(in.gcount()));
  }
  if (in.bad()) throw FileError(path + ": cannot read");
  return hex_of(hash.canonical_bytes());
}

std::string checksum_path(const std::string& path) {
  return path + ".xxh128";
}

void check_name_fits_checksum_line(const std::string& path) {
  const std::string name = std::filesystem::path(path).filename().string();
  if (name.find_first_of("\n\r") == std::string::npos) return;
  std::string shown;
  for (const char c : path)
    shown += c == '\n' ? std::string("\\n") : c == '\r' ? std::string("\\r") : std::string(1, c);
  throw FileError(shown +
                  ": a line break in the name, which its checksum file's one line cannot hold");
}

void write_checksum_file(const std::string& path, const std::string& hex) {
  check_name_fits_checksum_line(path);
  const std::string line = hex + "  " + std::filesystem::path(path).filename().string() + "\n";
  write_file_atomically(checksum_path(path), std::as_bytes(std::span(line.data(), line.size())));
}

std::string read_checksum_file(const std::string& path) {
  const std::string sidecar = checksum_path(path);
  std::error_code ec;
  if (!std::filesystem::exists(sidecar, ec)) return {};
  const std::string name = std::filesystem::path(path).filename().string();
  const std::string expected_form = sidecar + ": not one line \"CHECKSUM  " + name + "\"";
  if (std::filesystem::file_size(sidecar, ec) > 4096 || ec) throw FileError(expected_form);
  std::ifstream in(sidecar);
  std::string line, rest;
  if (!in || !std::getline(in, line) || std::getline(in, rest)) throw FileError(expected_form);
  const std::string hex = line.substr(0, std::min(line.size(), kDigits));
  if (!is_checksum_text(hex) || line.substr(kDigits) != "  " + name) throw FileError(expected_form);
  return hex;
}

}  // namespace basis
