// Reading, verifying and writing .qt files (FlatBuffers, schema formats/basis.fbs): one tree,
// a BRDF table or a capture set. A loaded file is one aligned buffer viewed in place.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "basis/brdf/brdf_table.h"
#include "basis/core/projection.h"
#include "basis/core/tree_set.h"
#include "basis/io/atomic_file.h"
#include "basis/lighting/capture_set.h"

namespace basis {

// The format version this build writes and the newest it reads. Version 2 added the capture
// sets' directional lights, version 3 packed trees (packed_tree.h), version 4 bounds for more
// than one channel group (the derivatives over the outgoing direction that tables hold),
// version 5 texel nodes of values alone in trees with exact texels (captures) and extents in
// words, version 6 the values of RGB trees with exact texels as shared-exponent words (4 bytes
// a quadrant instead of 6), version 7 those sets' nodes refined over all four quadrants as
// their link alone (refined_values.h), version 8 the checksum of the file's own bytes, which
// readers check before anything else in the file is used. Versions 3 to 6 load where they lie
// (the extents of 3 and 4 converted), and so do the other sets of versions 7 and 8; their capture
// sets have their derived values restored on loading; versions 1 and 2 their float trees packed
// on loading with largest-deviation (linf) bounds. Files before version 8 carry no checksum.
inline constexpr std::uint32_t kQtFormatVersion = 8;

// Limits checked before anything is allocated from a file's claims.
// FlatBuffers verifies buffers of fewer than 2^31 - 1 bytes.
inline constexpr std::uint64_t kQtMaxFileBytes = (std::uint64_t(1) << 31) - 2;
inline constexpr int kQtMaxWoResolution = 256;

enum class QtKind { tree, brdf_table, capture_set };
const char* to_string(QtKind kind);

// Where a file came from.
struct Provenance {
  std::string tool;
  std::string tool_version;
  std::string parameters;  // the tool's parameters, as JSON text
  std::vector<std::string> sources;
};

// A loaded and verified .qt file. Move-only; the views it returns live as long as it does.
class QtFile {
 public:
  // Reads and verifies a file. Throws FileError with one line "PATH: problem".
  static QtFile load(const std::string& path);
  // Verifies bytes held in memory (copied into aligned storage); `name` prefixes errors.
  static QtFile from_bytes(std::span<const std::byte> bytes, const std::string& name);

  // Verifies bytes where they lie (16-byte aligned, as encoders return them) with every check
  // load() makes; throws FileError with one line "NAME: problem".
  static void verify_bytes(std::span<const std::byte> bytes, const std::string& name);

  QtFile(QtFile&&) = default;
  QtFile& operator=(QtFile&&) = default;

  QtKind kind() const { return kind_; }
  std::uint32_t format_version() const { return version_; }
  const std::string& name() const { return name_; }
  std::size_t byte_size() const { return size_; }
  // The file's bytes as loaded and verified (for checksums of exactly what is used).
  std::span<const std::byte> bytes() const {
    return {static_cast<const std::byte*>(buffer()), size_};
  }

  TreeSetView trees() const { return trees_; }
  // Bytes of the trees' nodes and extents as the file stores them: trees().bytes() unless they
  // were packed or restored on loading (see zero_copy()).
  std::size_t stored_tree_bytes() const;
  ProjectionOptions projection() const { return projection_; }
  // The single tree of a kind-tree file (the first tree otherwise).
  PackedTreeView tree() const { return trees_.tree(0); }
  // Whether the file carried its checksum, which loading checked (format version 8 on).
  bool checksum_verified() const { return checksum_verified_; }
  // Whether the trees are used where they lie in the file (versions 3 to 6, and later versions'
  // sets without derived values) or were packed or restored on loading (versions 1 and 2, and
  // later versions' sets of shared-exponent values).
  bool zero_copy() const { return converted_.empty() && restored_words_.empty(); }
  // The table of a kind-brdf_table file; throws FileError for other kinds.
  BrdfTableView brdf_table() const;
  std::string brdf_model() const;
  std::string brdf_spec() const;
  // The captures of a kind-capture_set file; throws FileError for other kinds.
  CaptureSetView captures() const;
  Provenance provenance() const;

 private:
  QtFile() = default;
  void verify();
  // Checks one tree set of the buffer; `what` names it in errors.
  TreeSetView verify_tree_set(const void* set, const std::string& what,
                              ProjectionOptions* projection);
  // Versions 3 to 7: packed trees, checked where they lie (the extents of versions 3 and 4
  // converted), or restored into restored_words_ when their derived values were left out.
  TreeSetView verify_packed_trees(const void* set, const std::string& what,
                                  const QuadtreeShape& shape);
  // The elided layout's trees restored (in parallel) into restored_words_, each checked as it is
  // read.
  TreeSetView restore_elided_trees(const PackedShape& shape, std::span<const TreeExtent> extents,
                                   std::span<const std::uint32_t> words, const std::string& what);
  // Versions 1 and 2: float trees, checked and packed into converted_.
  TreeSetView verify_and_pack_float_trees(const void* set, const std::string& what,
                                          const QuadtreeShape& shape);
  // The file's bytes, 16-byte aligned: a read-only memory map of a file, or a copy in memory.
  class Buffer {
   public:
    Buffer() = default;
    Buffer(Buffer&& other) noexcept { *this = std::move(other); }
    Buffer& operator=(Buffer&& other) noexcept;
    ~Buffer() { release(); }
    static Buffer map_file(int fd, std::size_t size);
    static Buffer copy_of(std::span<const std::byte> bytes);
    static Buffer borrow(std::span<const std::byte> bytes);  // not owned: bytes must outlive it
    const void* data() const { return data_; }

   private:
    void release() noexcept;
    const void* data_ = nullptr;
    std::size_t mapped_size_ = 0;  // nonzero for a memory map
    std::unique_ptr<Quad[]> copy_;
  };
  const void* buffer() const { return storage_.data(); }

  Buffer storage_;
  std::size_t size_ = 0;
  std::string name_;
  QtKind kind_ = QtKind::tree;
  std::uint32_t version_ = 0;
  bool checksum_verified_ = false;
  ProjectionOptions projection_;
  TreeSetView trees_;
  TreeSetView tilt_;
  std::vector<TreeSet> converted_;  // trees of versions 1 and 2, packed
  // Words restored from the sets of version 7 and later: memory left uninitialised until the
  // trees are written into it; from 2 MiB on, a mapping of its own asked for on huge pages
  // (restore_elided_trees).
  struct FreeWords {
    std::size_t mapped_bytes = 0;  // nonzero for a mapping
    void operator()(std::uint32_t* words) const noexcept;
  };
  std::vector<std::unique_ptr<std::uint32_t[], FreeWords>> restored_words_;
  // Extents of versions 3 and 4, converted, and of restored sets (version 7 and later).
  std::vector<std::vector<TreeExtent>> converted_extents_;
  // Restored trees' PackedTreeView::derived_rounding, one vector per restored set.
  std::vector<std::vector<float>> derived_roundings_;
  int wo_resolution_ = 0;
  CaptureSetView captures_;
};

// Complete .qt buffers (the current version). Each is verified with the loader's checks before it
// is returned, so that no file is written that load() would refuse. Throw std::invalid_argument for
// inconsistent input and for content the loader refuses (NaN or infinite values, negative bounds,
// links out of order, frames that are not unit vectors, lights below the horizon, ...).
std::vector<std::byte> encode_tree(const PackedTreeView& tree, const ProjectionOptions& projection,
                                   const Provenance& provenance);
std::vector<std::byte> encode_brdf_table(const BrdfTableView& table, const std::string& model,
                                         const std::string& spec,
                                         const ProjectionOptions& projection,
                                         const Provenance& provenance);
std::vector<std::byte> encode_capture_set(const CaptureSetView& captures,
                                          const ProjectionOptions& projection,
                                          const Provenance& provenance);

// Writes into a .qt buffer's checksum field the XXH3-128 of all its bytes, the field's 16 read as
// zeros; false, changing nothing, for bytes without a sound structure holding the field.
bool seal_qt_checksum(std::span<std::byte> bytes);

// Writes an encoded buffer atomically (see atomic_file.h).
void write_qt(const std::string& path, std::span<const std::byte> encoded);

}  // namespace basis
