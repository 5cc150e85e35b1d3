// Checksums of bytes and files: XXH3-128 (xxHash, from Debian's libxxhash), as the 32 lowercase
// hex digits xxh128sum prints, and checksum files beside the files they describe. A checksum
// catches a file altered or damaged after it was written (any change, with odds of 2^-128 of
// missing it); it is not a signature against deliberate forgery.
#pragma once

#include <array>
#include <cstddef>
#include <initializer_list>
#include <span>
#include <string>

#include "basis/core/file_error.h"

namespace basis {

// The XXH3-128 of `bytes`, 32 lowercase hex digits (most significant first, as xxh128sum).
std::string checksum_hex(std::span<const std::byte> bytes);

// The XXH3-128 of the pieces' bytes one after the other: checksum_hex of their concatenation.
std::string pieces_checksum_hex(std::initializer_list<std::span<const std::byte>> pieces);

// The XXH3-128 of the pieces' bytes one after the other as its 16 canonical bytes (most
// significant first: the bytes the hex digits above spell).
std::array<std::byte, 16> pieces_checksum_bytes(
    std::initializer_list<std::span<const std::byte>> pieces);

// The XXH3-128 of a file's contents, read in pieces. Throws FileError naming the file when it
// cannot be read.
std::string file_checksum_hex(const std::string& path);

// Where the checksum of `path` is kept: PATH.xxh128, one line "HEX  NAME" (NAME the file's name
// without its folder, as `xxh128sum NAME` prints it, so that `xxh128sum -c` checks it there).
std::string checksum_path(const std::string& path);

// Throws FileError when `path`'s file name cannot stand in its checksum file's one line: it
// holds a line break (\n or \r). The message shows each break escaped, so that it stays one
// line.
void check_name_fits_checksum_line(const std::string& path);

// Writes the checksum file of `path` atomically, saying `hex` (check_name_fits_checksum_line
// first).
void write_checksum_file(const std::string& path, const std::string& hex);

// The checksum recorded beside `path`, or an empty string when there is none. Throws FileError
// for a checksum file that is not one line "HEX  NAME" naming this file.
std::string read_checksum_file(const std::string& path);

// Whether `text` has the form of a checksum: 32 lowercase hex digits.
bool is_checksum_text(const std::string& text);

}  // namespace basis
