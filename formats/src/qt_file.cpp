#include "basis/format/qt_file.h"
#include "basis/core/projection.h"
#include "basis/core/refined_values.h"
#include "basis/io/checksum.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <utility>

#include "basis_generated.h"
#include "tbb/blocked_range.h"
#include "tbb/parallel_for.h"

namespace basis {

namespace fb = basis::format;

static_assert(sizeof(Quad) == sizeof(fb::Quad) && alignof(Quad) == alignof(fb::Quad));
static_assert(sizeof(TreeExtent) == sizeof(fb::NodeExtent) &&
              alignof(TreeExtent) == alignof(fb::NodeExtent));
static_assert(std::endian::native == std::endian::little,
              "packed nodes hold halves and bytes inside little-endian words");
static_assert(sizeof(Vec3) == sizeof(fb::Vec3) && alignof(Vec3) == alignof(fb::Vec3));
static_assert(sizeof(DirectionalLight) == sizeof(fb::Light) &&
              alignof(DirectionalLight) == alignof(fb::Light));

const char* to_string(QtKind kind) {
  switch (kind) {
    case QtKind::tree:
      return "tree";
    case QtKind::brdf_table:
      return "brdf-table";
    case QtKind::capture_set:
      return "capture-set";
  }
  return "unknown";
}

namespace {

[[noreturn]] void fail(const std::string& name, const std::string& problem) {
  throw FileError(name + ": " + problem);
}

// A vector of structs viewed in place; a vector not aligned for T (the verifier checks only
// 4 bytes) is an error naming `what`.
template <typename T, typename F>
std::span<const T> as_span(const flatbuffers::Vector<const F*>* v, const std::string& name,
                           const char* what) {
  if (!v || v->size() == 0) return {};
  if (reinterpret_cast<std::uintptr_t>(v->Data()) % alignof(T) != 0)
    fail(name, std::string(what) + " are misaligned (corrupt file)");
  return {reinterpret_cast<const T*>(v->Data()), v->size()};
}

// All value quads (every quad but each node's first, the links) are finite.
bool values_finite(std::span<const Quad> nodes, std::size_t stride) {
  for (std::size_t n = 0; n < nodes.size(); n += stride)
    if (!all_finite({nodes[n + 1].lane, (stride - 1) * 4})) return false;
  return true;
}

std::span<const float> lanes(std::span<const Quad> quads) {
  return {reinterpret_cast<const float*>(quads.data()), quads.size() * 4};
}

bool finite_unit_frames(std::span<const Vec3> values, bool unit) {
  for (const Vec3& p : values) {
    if (!p.allFinite()) return false;
    if (unit && std::abs(p.squaredNorm() - 1) > 1e-3) return false;
  }
  return true;
}

// Child links, depths and values of one tree; returns an empty string or the problem.
std::string check_tree(const QuadtreeView& tree, int levels, std::vector<std::uint8_t>& depth) {
  const int count = tree.node_count();
  if (count < 1) return "a tree has no nodes";
  depth.assign(count, 0xff);
  depth[0] = 0;
  for (int node = 0; node < count; ++node) {
    if (depth[node] == 0xff) return "node " + std::to_string(node) + " is unreachable";
    for (int q = 0; q < 4; ++q) {
      const std::int32_t child = tree.child(node, q);
      if (child == 0) continue;
      if (child <= node || child >= count)
        return "node " + std::to_string(node) + " links to node " + std::to_string(child) +
               " (children must follow their parent, " + std::to_string(count) + " nodes)";
      if (depth[child] != 0xff) return "node " + std::to_string(child) + " has two parents";
      depth[child] = std::uint8_t(depth[node] + 1);
      if (depth[child] >= levels)
        return "tree deeper than its resolution allows (" + std::to_string(levels) + " levels)";
    }
  }
  return {};
}

// Links and depths of one packed tree: breadth first, node n's children the next block after
// those of the nodes before it; with exact texels, exactly the nodes at the texel depth are
// texel nodes. Returns an empty string or the problem.
std::string link_problem(const PackedTreeView& tree, std::vector<std::uint8_t>& depth) {
  const PackedShape& shape = tree.shape();
  const int levels = std::countr_zero(unsigned(shape.resolution));
  const int count = tree.node_count();
  depth.assign(std::size_t(count), 0);
  std::uint64_t next = 1;
  for (int n = 0; n < count; ++n) {
    if (std::uint64_t(n) >= next) return "node " + std::to_string(n) + " is unreachable";
    if (shape.exact_texels && (depth[n] == shape.texel_depth()) != tree.is_texel_node(n))
      return "texel nodes start at node " + std::to_string(tree.texel_start()) + ", node " +
             std::to_string(n) + " lies at depth " + std::to_string(depth[n]);
    const std::uint32_t link = tree.link(n);
    if (link == 0) continue;
    if ((link & 15u) == 0 || link >> 4 != next)
      return "node " + std::to_string(n) + " links to node " + std::to_string(link >> 4) +
             " (children follow breadth first, expected " + std::to_string(next) + ")";
    const int children = std::popcount(link & 15u);
    if (next + std::uint64_t(children) > std::uint64_t(count))
      return "node " + std::to_string(n) + " links past the tree's " + std::to_string(count) +
             " nodes";
    if (depth[n] + 1 >= levels)
      return "deeper than its resolution allows (" + std::to_string(levels) + " levels)";
    for (int k = 0; k < children; ++k)
      depth[next + k] = std::uint8_t(depth[n] + 1);
    next += std::uint64_t(children);
  }
  if (next != std::uint64_t(count)) return std::to_string(count - next) + " nodes are unreachable";
  return {};
}

// What is wrong with a tree's extent in a set with or without exact texels ("" if nothing).
std::string extent_problem(const TreeExtent& e, bool exact_texels) {
  if (e.node_count == 0) return "a tree has no nodes";
  if (e.texel_start > e.node_count || (!exact_texels && e.texel_start != e.node_count))
    return "a tree's first texel node " + std::to_string(e.texel_start) + " is past its " +
           std::to_string(e.node_count) + " nodes" +
           (exact_texels ? "" : ", or set without exact texels");
  if (!(e.scales.value_scale > 0 && e.scales.value_scale < INFINITY) ||
      !(e.scales.bound_scale > 0 && e.scales.bound_scale < INFINITY))
    return "a tree's scales are not finite positive numbers";
  // Scales packing never writes: a value scale that is not a power of two up to 2^110, a bound
  // scale above 2^125. Within them every stored half, shared-exponent word and bound code decodes
  // to a finite float.
  int exponent = 0;
  if (std::frexp(e.scales.value_scale, &exponent) != 0.5f ||
      e.scales.value_scale > kLargestValueScale)
    return "a tree's value scale " + std::to_string(e.scales.value_scale) +
           " is not a power of two up to 2^110";
  if (e.scales.bound_scale > kLargestBoundScale)
    return "a tree's bound scale " + std::to_string(e.scales.bound_scale) + " exceeds 2^125";
  return {};
}

// Where the checksum field's 16 bytes lie in a verified buffer.
std::size_t checksum_offset(const std::uint8_t* bytes, const fb::Checksum& stored) {
  return std::size_t(stored.bytes()->Data() - bytes);
}

// The checksum a buffer should carry: its bytes' XXH3-128 with the field's 16 read as zeros.
std::array<std::byte, 16> expected_checksum(std::span<const std::byte> bytes, std::size_t at) {
  const std::array<std::byte, 16> zeros{};
  return pieces_checksum_bytes({bytes.first(at), zeros, bytes.subspan(at + zeros.size())});
}

// Opens a regular file of at most the format's size; returns its descriptor and size.
std::pair<int, std::size_t> open_regular_file(const std::string& path) {
  // Without blocking, so that a FIFO is refused below instead of waiting for a writer.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) fail(path, std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    fail(path, std::strerror(e));
  }
  std::string problem;
  if (S_ISDIR(st.st_mode))
    problem = "is a directory, not a .qt file";
  else if (!S_ISREG(st.st_mode))
    problem = "is not a regular file";
  else if (std::uint64_t(st.st_size) > kQtMaxFileBytes)
    problem = "file of " + std::to_string(st.st_size) + " bytes exceeds the 2 GiB format limit";
  if (!problem.empty()) {
    ::close(fd);
    fail(path, problem);
  }
  return {fd, std::size_t(st.st_size)};
}

}  // namespace

QtFile::Buffer& QtFile::Buffer::operator=(Buffer&& other) noexcept {
  if (this != &other) {
    release();
    data_ = std::exchange(other.data_, nullptr);
    mapped_size_ = std::exchange(other.mapped_size_, 0);
    copy_ = std::move(other.copy_);
  }
  return *this;
}

void QtFile::Buffer::release() noexcept {
  if (mapped_size_) ::munmap(const_cast<void*>(data_), mapped_size_);
  data_ = nullptr;
  mapped_size_ = 0;
  copy_.reset();
}

QtFile::Buffer QtFile::Buffer::map_file(int fd, std::size_t size) {
  Buffer b;
  if (size == 0) return b;
  void* p = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
  if (p == MAP_FAILED) return b;
  b.data_ = p;
  b.mapped_size_ = size;
  return b;
}

QtFile::Buffer QtFile::Buffer::copy_of(std::span<const std::byte> bytes) {
  Buffer b;
  b.copy_ =
      std::make_unique_for_overwrite<Quad[]>((bytes.size() + sizeof(Quad) - 1) / sizeof(Quad));
  if (!bytes.empty()) std::memcpy(b.copy_.get(), bytes.data(), bytes.size());
  b.data_ = b.copy_.get();
  return b;
}

QtFile::Buffer QtFile::Buffer::borrow(std::span<const std::byte> bytes) {
  Buffer b;
  b.data_ = bytes.data();
  return b;
}

void QtFile::verify_bytes(std::span<const std::byte> bytes, const std::string& name) {
  QtFile file;
  file.name_ = name;
  if (bytes.size() > kQtMaxFileBytes) fail(name, "buffer exceeds the 2 GiB format limit");
  file.size_ = bytes.size();
  file.storage_ = Buffer::borrow(bytes);
  file.verify();
}

QtFile QtFile::load(const std::string& path) {
  QtFile file;
  file.name_ = path;
  const auto [fd, size] = open_regular_file(path);
  file.size_ = size;
  // A read-only map of the page cache: the trees are convolved where they lie (zero copy).
  file.storage_ = Buffer::map_file(fd, size);
  const int map_error = errno;
  ::close(fd);
  if (size > 0 && !file.storage_.data())
    fail(path, std::string("cannot map: ") + std::strerror(map_error));
  file.verify();
  return file;
}

QtFile QtFile::from_bytes(std::span<const std::byte> bytes, const std::string& name) {
  QtFile file;
  file.name_ = name;
  if (bytes.size() > kQtMaxFileBytes) fail(name, "buffer exceeds the 2 GiB format limit");
  file.size_ = bytes.size();
  file.storage_ = Buffer::copy_of(bytes);
  file.verify();
  return file;
}

void QtFile::verify() {
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(buffer());
  if (size_ == 0) fail(name_, "empty file, not a .qt file");
  if (size_ < 8 || !fb::FileBufferHasIdentifier(bytes))
    fail(name_, "not a .qt file (no BQTF identifier)");
  flatbuffers::Verifier verifier(bytes, size_);
  if (!fb::VerifyFileBuffer(verifier))
    fail(name_, "corrupt or truncated .qt file (structure check failed)");
  const fb::File* root = fb::GetFile(bytes);
  version_ = root->format_version();
  if (version_ > kQtFormatVersion)
    fail(name_, "format version " + std::to_string(version_) + " is newer than this build reads (" +
                    std::to_string(kQtFormatVersion) + ")");
  if (version_ == 0) fail(name_, "format version 0 is not a valid .qt version");
  // Before anything the file holds is used; whatever version it claims, so that a changed
  // version cannot turn the check off.
  if (const fb::Checksum* stored = root->checksum()) {
    const std::span<const std::byte> all(reinterpret_cast<const std::byte*>(bytes), size_);
    const std::size_t at = checksum_offset(bytes, *stored);
    if (std::memcmp(expected_checksum(all, at).data(), bytes + at, 16) != 0)
      fail(name_,
           "checksum mismatch: the file's bytes changed after it was written (damaged, cut short "
           "or added to); write it again");
    checksum_verified_ = true;
  } else if (version_ >= 8) {
    fail(name_, "no checksum, which format version " + std::to_string(version_) +
                    " files carry (corrupt file)");
  }
  if (root->mapping() != fb::Mapping::CosineConcentric)
    fail(name_, "unknown mapping " + std::to_string(int(root->mapping())));
  switch (root->kind()) {
    case fb::Kind::Tree:
      kind_ = QtKind::tree;
      break;
    case fb::Kind::BrdfTable:
      kind_ = QtKind::brdf_table;
      break;
    case fb::Kind::CaptureSet:
      kind_ = QtKind::capture_set;
      break;
    default:
      fail(name_, "unknown content kind " + std::to_string(int(root->kind())));
  }

  trees_ = verify_tree_set(root->trees(), "trees", &projection_);

  if (kind_ == QtKind::tree && trees_.size() != 1)
    fail(name_, "a single-tree file holds " + std::to_string(trees_.size()) + " trees");
  if (kind_ == QtKind::brdf_table) {
    const fb::BrdfTable* table = root->brdf_table();
    if (!table) fail(name_, "BRDF table parameters are missing");
    wo_resolution_ = table->wo_resolution();
    if (wo_resolution_ < 2 || wo_resolution_ > kQtMaxWoResolution)
      fail(name_, "outgoing-direction resolution " + std::to_string(wo_resolution_) +
                      " outside 2.." + std::to_string(kQtMaxWoResolution));
    if (trees_.size() != std::size_t(wo_resolution_) * wo_resolution_)
      fail(name_, "BRDF table of " + std::to_string(wo_resolution_) + "^2 entries holds " +
                      std::to_string(trees_.size()) + " trees");
    // One group (f), or three with bounds for all (f and its derivatives over wo).
    if (trees_.shape().groups == 2 ||
        (trees_.shape().groups == 3 && trees_.shape().bounded_groups != 3))
      fail(name_, "BRDF table entries hold " + std::to_string(trees_.shape().groups) +
                      " groups with bounds for " + std::to_string(trees_.shape().bounded_groups) +
                      " (1, or 3 with bounds for all, expected)");
    // Entries are texel averages over wi, not exact texels (what captures hold).
    if (trees_.shape().exact_texels)
      fail(name_, "BRDF table entries marked as exact texels, which only captures hold");
    if (table->tilt()) {
      tilt_ = verify_tree_set(table->tilt(), "tilt trees", nullptr);
      if (tilt_.size() != trees_.size() || tilt_.shape().groups != 2 ||
          tilt_.shape().channels != trees_.shape().channels)
        fail(name_, "tilt trees do not match the table's entries (count, channels, two groups)");
    }
  }
  if (kind_ == QtKind::capture_set) {
    const fb::CaptureSet* set_info = root->capture_set();
    if (!set_info) fail(name_, "capture positions are missing");
    captures_.positions = as_span<Vec3>(set_info->positions(), name_, "capture positions");
    captures_.normals = as_span<Vec3>(set_info->normals(), name_, "capture normals");
    captures_.tangents = as_span<Vec3>(set_info->tangents(), name_, "capture tangents");
    captures_.trees = trees_;
    if (captures_.positions.size() != trees_.size() || captures_.normals.size() != trees_.size() ||
        captures_.tangents.size() != trees_.size())
      fail(name_, "capture positions, normals and tangents do not match the " +
                      std::to_string(trees_.size()) + " trees");
    if (!finite_unit_frames(captures_.positions, false))
      fail(name_, "a capture position is NaN or infinite");
    if (!finite_unit_frames(captures_.normals, true) ||
        !finite_unit_frames(captures_.tangents, true))
      fail(name_, "a capture normal or tangent is not a unit vector");
    for (std::size_t i = 0; i < captures_.size(); ++i) {
      if (std::abs(captures_.normals[i].dot(captures_.tangents[i])) > 1e-3)
        fail(name_, "capture " + std::to_string(i) + ": tangent is not orthogonal to the normal");
    }
    captures_.lights = as_span<DirectionalLight>(set_info->lights(), name_, "capture lights");
    if (const auto* offsets = set_info->light_offsets())
      captures_.light_offsets = {offsets->data(), offsets->size()};
    if (!captures_.light_offsets.empty() || !captures_.lights.empty()) {
      const auto& offsets = captures_.light_offsets;
      if (offsets.size() != captures_.size() + 1 || offsets.front() != 0 ||
          offsets.back() != captures_.lights.size() ||
          !std::is_sorted(offsets.begin(), offsets.end()))
        fail(name_, "capture light offsets do not match the captures and their lights");
      for (std::size_t i = 0; i < captures_.lights.size(); ++i) {
        const DirectionalLight& l = captures_.lights[i];
        const Color& e = l.energy;
        if (!finite_unit_frames({&l.direction, 1}, true) || !(l.direction.z() > 0) ||
            !std::isfinite(e[0]) || !std::isfinite(e[1]) || !std::isfinite(e[2]) || e[0] < 0 ||
            e[1] < 0 || e[2] < 0 || std::max({e[0], e[1], e[2]}) > 3e38)
          fail(name_, "capture light " + std::to_string(i) +
                          ": direction not a unit vector above the horizon, or energy negative "
                          "or not finite");
      }
    }
  }
}

BrdfTableView QtFile::brdf_table() const {
  if (kind_ != QtKind::brdf_table)
    fail(name_, std::string("holds a ") + to_string(kind_) + ", not a BRDF table");
  return {wo_resolution_, trees_, tilt_};
}

TreeSetView QtFile::verify_tree_set(const void* set_pointer, const std::string& what,
                                    ProjectionOptions* projection) {
  const auto* set = static_cast<const fb::TreeSet*>(set_pointer);
  if (!set) fail(name_, "no " + what);
  const QuadtreeShape shape{set->resolution(), set->channels(), set->groups()};
  if (!is_valid_resolution(shape.resolution))
    fail(name_, what + ": resolution " + std::to_string(shape.resolution) +
                    " is not a power of two from 2 to 512");
  if (shape.channels != 1 && shape.channels != 3)
    fail(name_, what + ": " + std::to_string(shape.channels) + " channels (1 or 3 expected)");
  if (shape.groups < 1 || shape.groups > 3)
    fail(name_, what + ": " + std::to_string(shape.groups) + " channel groups (1 to 3 expected)");
  const int levels = std::countr_zero(unsigned(shape.resolution));
  ProjectionOptions p;
  p.tolerance = set->tolerance();
  if (!std::isfinite(p.tolerance) || p.tolerance < 0)
    fail(name_, what + ": tolerance is not a finite number >= 0");
  if (set->tolerance_mode() != fb::ToleranceMode::Relative &&
      set->tolerance_mode() != fb::ToleranceMode::Absolute)
    fail(name_, what + ": unknown tolerance mode");
  p.mode = set->tolerance_mode() == fb::ToleranceMode::Relative ? ProjectionOptions::Mode::relative
                                                                : ProjectionOptions::Mode::absolute;
  p.max_depth = set->max_depth();
  p.local_floor = set->tolerance_floor();
  if (!std::isfinite(p.local_floor) || p.local_floor < 0)
    fail(name_, what + ": tolerance floor is not a finite number >= 0");
  if (p.max_depth < 0 || p.max_depth > levels)
    fail(name_, what + ": max depth " + std::to_string(p.max_depth) + " outside 0.." +
                    std::to_string(levels));
  if (projection) *projection = p;
  return version_ >= 3 ? verify_packed_trees(set, what, shape)
                       : verify_and_pack_float_trees(set, what, shape);
}

void QtFile::FreeWords::operator()(std::uint32_t* words) const noexcept {
  if (mapped_bytes > 0)
    ::munmap(words, mapped_bytes);
  else
    std::free(words);
}

TreeSetView QtFile::restore_elided_trees(const PackedShape& shape,
                                         std::span<const TreeExtent> extents,
                                         std::span<const std::uint32_t> words,
                                         const std::string& what) {
  auto out_of_memory = [&] {
    fail(name_, what + ": not enough memory to restore the trees' refined values");
  };
  const int levels = std::countr_zero(unsigned(shape.resolution));
  const std::uint64_t largest_tree = ((std::uint64_t(1) << (2 * levels)) - 1) / 3;
  const std::size_t count = extents.size();
  // Where each tree goes in the restored set, allocated once: at most 8 words in memory per word
  // stored (a tree whose extent is refused below takes none). Trees past that are still checked,
  // and the first tree that does not fit is refused in its place in the trees' order.
  std::vector<TreeExtent> restored_extents(extents.begin(), extents.end());
  std::uint64_t restored_words = 0;
  for (TreeExtent& e : restored_extents) {
    e.first_word = std::uint32_t(std::min<std::uint64_t>(restored_words, UINT32_MAX));
    if (e.texel_start <= e.node_count && e.node_count <= largest_tree)
      restored_words += packed_node_offset(shape, e.texel_start, e.node_count);
  }
  const std::uint64_t allocated =
      std::min({restored_words, 8 * std::uint64_t(words.size()), std::uint64_t(UINT32_MAX)});
  // Not zero-filled: every word is written before the set is used, by the tree it belongs to, so
  // that the pages are first touched in parallel. From 2 MiB on, a mapping of its own asked for
  // on huge pages (transparent huge pages on request), so that the restoring faults once per 2
  // MiB, not 4 KiB, and gives the memory back when the file is closed.
  constexpr std::size_t kHugePage = std::size_t(2) << 20;
  const std::size_t bytes =
      std::max<std::size_t>(std::size_t(allocated) * sizeof(std::uint32_t), 1);
  std::unique_ptr<std::uint32_t[], FreeWords> memory;
  if (bytes >= kHugePage) {
    void* mapped =
        ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapped == MAP_FAILED) out_of_memory();
    memory = {static_cast<std::uint32_t*>(mapped), FreeWords{bytes}};
    ::madvise(mapped, bytes, MADV_HUGEPAGE);  // a request; may be refused
  } else {
    memory.reset(static_cast<std::uint32_t*>(std::malloc(bytes)));
    if (!memory) out_of_memory();
  }
  const std::span<std::uint32_t> restored(memory.get(), std::size_t(allocated));
  // Each tree read from its first word on, checked and restored into its place, in parallel;
  // what refused it is reported below in the trees' order, as a reading in order meets it.
  struct Outcome {
    std::string extent_problem, tree_problem;
    bool out_of_memory = false, does_not_fit = false;
    std::uint64_t words_read = 0;
  };
  std::vector<Outcome> outcomes(count);
  std::vector<float> derived_roundings(count, 1.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 16), [&](const auto& range) {
    PackedTree read;
    std::vector<double> scratch;
    std::vector<std::uint8_t> depth;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const TreeExtent& e = extents[i];
      Outcome& out = outcomes[i];
      out.extent_problem = extent_problem(e, shape.exact_texels);
      if (!out.extent_problem.empty()) continue;
      if (e.first_word > words.size()) {
        out.tree_problem = "starts at word " + std::to_string(e.first_word) + ", past the " +
                           std::to_string(words.size()) + " the node data hold";
        continue;
      }
      if (e.node_count > largest_tree) {
        out.tree_problem = std::to_string(e.node_count) + " nodes, more than a tree of " +
                           std::to_string(shape.resolution) + "² holds";
        continue;
      }
      try {
        out.words_read = read_elided_tree(shape, e.scales, words.subspan(e.first_word),
                                          e.node_count, e.texel_start, read);
        if (out.tree_problem = link_problem(read.view(), depth); !out.tree_problem.empty())
          continue;
        derive_refined_values(read, DerivedBoundRange::refuse, scratch);
        derived_roundings[i] = read.derived_rounding;
      } catch (const std::invalid_argument& error) {
        out.tree_problem = error.what();
        continue;
      } catch (const std::bad_alloc&) {
        out.out_of_memory = true;
        continue;
      }
      // A tree read whole fits: a left-out node's link word restores to a full node of 8
      // words, every other word to itself. Only trees after one refused (whose places were
      // counted from their extents), or a set of over 2^32 words, reach past the allocation.
      const std::uint64_t place = restored_extents[i].first_word;
      if (place + read.words.size() > allocated) {
        out.does_not_fit = true;
        continue;
      }
      std::copy(read.words.begin(), read.words.end(), restored.begin() + std::ptrdiff_t(place));
    }
  });
  std::uint64_t total = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const Outcome& out = outcomes[i];
    if (extents[i].first_word != total) fail(name_, what + ": tree extents are not contiguous");
    if (!out.extent_problem.empty()) fail(name_, what + ": " + out.extent_problem);
    if (!out.tree_problem.empty())
      fail(name_, what + ": tree " + std::to_string(i) + ": " + out.tree_problem);
    if (out.out_of_memory) out_of_memory();
    if (out.does_not_fit)
      fail(name_, what + ": tree " + std::to_string(i) +
                      ": the trees' nodes restore to more words than the set can hold");
    total += out.words_read;
  }
  if (words.size() != total)
    fail(name_, what + ": node data hold " + std::to_string(words.size()) + " words, " +
                    std::to_string(total) + " expected");
  restored_words_.push_back(std::move(memory));
  const std::vector<TreeExtent>& kept =
      converted_extents_.emplace_back(std::move(restored_extents));
  return TreeSetView(shape, kept, restored,
                     derived_roundings_.emplace_back(std::move(derived_roundings)));
}

TreeSetView QtFile::verify_packed_trees(const void* set_pointer, const std::string& what,
                                        const QuadtreeShape& s) {
  const auto* set = static_cast<const fb::TreeSet*>(set_pointer);
  if (set->bounds() != fb::BoundKind::L2 && set->bounds() != fb::BoundKind::Linf)
    fail(name_, what + ": unknown bound kind " + std::to_string(int(set->bounds())));
  const int bounded_groups = set->bounded_groups();
  if (bounded_groups < 1 || bounded_groups > s.groups)
    fail(name_, what + ": bounds for " + std::to_string(bounded_groups) + " of " +
                    std::to_string(s.groups) + " channel groups");
  const bool exact_texels = version_ >= 5 && set->exact_texels();
  PackedShape shape{
      s.resolution,   s.channels,
      s.groups,       set->bounds() == fb::BoundKind::L2 ? BoundKind::l2 : BoundKind::linf,
      bounded_groups, exact_texels};
  if (version_ >= 6 && set->value_encoding() != fb::ValueEncoding::Halves) {
    if (set->value_encoding() != fb::ValueEncoding::SharedExponent)
      fail(name_, what + ": unknown value encoding " + std::to_string(int(set->value_encoding())));
    if (!exact_texels || s.channels != 3 || s.groups != 1)
      fail(name_, what + ": shared-exponent values need exact texels, 3 channels and one group");
    shape.value_encoding = ValueEncoding::shared_exponent;
  }
  std::span<const TreeExtent> extents;
  if (version_ >= 5) {
    extents = as_span<TreeExtent>(set->node_extents(), name_, "tree extents");
  } else {  // versions 3 and 4: nodes counted from the set's first, all of them full
    struct NodeCountExtent {
      std::uint32_t first_node, node_count;
      TreeScales scales;
    };
    const auto old = as_span<NodeCountExtent>(set->packed_extents(), name_, "tree extents");
    std::vector<TreeExtent>& converted = converted_extents_.emplace_back();
    converted.reserve(old.size());
    const std::uint64_t per_node = std::uint64_t(shape.words_per_node());
    for (const NodeCountExtent& e : old) {
      if (std::uint64_t(e.first_node) * per_node > UINT32_MAX)
        fail(name_, what + ": tree extents lie past 2^32 words");
      converted.push_back(
          {std::uint32_t(e.first_node * per_node), e.node_count, e.node_count, e.scales});
    }
    extents = converted;
  }
  std::span<const std::uint32_t> words;
  if (set->words()) words = {set->words()->data(), set->words()->size()};
  if (extents.empty()) fail(name_, "no " + what);
  const bool elided = version_ >= 7 && set->refined_values_elided();
  if (elided && !has_derived_values(shape))
    fail(name_, what + ": only sets of shared-exponent values leave out refined nodes' values");
  if (elided) return restore_elided_trees(shape, extents, words, what);
  std::uint64_t total = 0;
  for (const TreeExtent& e : extents) {
    if (e.first_word != total) fail(name_, what + ": tree extents are not contiguous");
    if (const std::string problem = extent_problem(e, exact_texels); !problem.empty())
      fail(name_, what + ": " + problem);
    total += e.word_count(shape);
    if (total > words.size()) break;
  }
  if (words.size() != total)
    fail(name_, what + ": node data hold " + std::to_string(words.size()) + " words, " +
                    (total > words.size() ? "more" : std::to_string(total)) + " expected");
  // Each tree's links and values checked, in parallel; the first tree refused is reported.
  const TreeSetView view(shape, extents, words);
  std::vector<std::string> problems(view.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, view.size(), 16), [&](const auto& range) {
    std::vector<std::uint8_t> depth;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const PackedTreeView tree = view.tree(i);
      if (std::string problem = link_problem(tree, depth); !problem.empty()) {
        problems[i] = "tree " + std::to_string(i) + ": " + problem;
        continue;
      }
      // Values: halves that are neither infinite nor NaN (exponent bits all ones). Every
      // shared-exponent word is a finite value.
      const int halves = 2 * shape.groups * shape.channels * 2;
      for (int n = 0; n < (shape.shared_values() ? 0 : tree.node_count()); ++n) {
        const std::uint16_t* h = tree.halves(n);
        for (int k = 0; k < halves; ++k)
          if ((h[k] & 0x7c00u) == 0x7c00u) problems[i] = "a node holds a NaN or infinite value";
        if (!problems[i].empty()) break;
      }
    }
  });
  for (const std::string& problem : problems)
    if (!problem.empty()) fail(name_, what + ": " + problem);
  return view;
}

TreeSetView QtFile::verify_and_pack_float_trees(const void* set_pointer, const std::string& what,
                                                const QuadtreeShape& shape) {
  const auto* set = static_cast<const fb::TreeSet*>(set_pointer);
  const int levels = std::countr_zero(unsigned(shape.resolution));
  struct FloatExtent {
    std::uint32_t first_node, node_count;
  };
  const auto extents = as_span<FloatExtent>(set->extents(), name_, "tree extents");
  const auto nodes = as_span<Quad>(set->nodes(), name_, "tree nodes");
  const auto errors = as_span<Quad>(set->errors(), name_, "tree error bounds");
  if (extents.empty()) fail(name_, "no " + what);
  std::uint64_t total = 0;
  for (const FloatExtent& e : extents) {
    if (e.first_node != total) fail(name_, what + ": tree extents are not contiguous");
    if (e.node_count == 0) fail(name_, what + ": a tree has no nodes");
    total += e.node_count;
  }
  if (nodes.size() != total * shape.stride())
    fail(name_, what + ": node data hold " + std::to_string(nodes.size()) + " quads, " +
                    std::to_string(total * shape.stride()) + " expected");
  if (errors.size() != total * shape.channels)
    fail(name_, what + ": error bounds hold " + std::to_string(errors.size()) + " quads, " +
                    std::to_string(total * shape.channels) + " expected");
  if (!values_finite(nodes, shape.stride()))
    fail(name_, what + ": a node holds a NaN or infinite value");
  if (!all_finite(lanes(errors))) fail(name_, what + ": an error bound is NaN or infinite");
  for (const Quad& q : errors)
    for (float e : q.lane)
      if (e < 0) fail(name_, what + ": an error bound is negative");
  // Each tree checked, then packed with its error bounds (linf).
  TreeSet packed(PackedShape{shape.resolution, shape.channels, shape.groups, BoundKind::linf});
  std::vector<std::uint8_t> depth;
  for (std::size_t i = 0; i < extents.size(); ++i) {
    const FloatExtent& e = extents[i];
    Quadtree tree;
    tree.shape = shape;
    tree.nodes.assign(nodes.begin() + std::size_t(e.first_node) * shape.stride(),
                      nodes.begin() + std::size_t(e.first_node + e.node_count) * shape.stride());
    tree.errors.assign(errors.begin() + std::size_t(e.first_node) * shape.channels,
                       errors.begin() + std::size_t(e.first_node + e.node_count) * shape.channels);
    if (const std::string problem = check_tree(tree.view(), levels, depth); !problem.empty())
      fail(name_, what + ": tree " + std::to_string(i) + ": " + problem);
    try {
      packed.append(pack(tree, BoundKind::linf).view());
    } catch (const std::overflow_error& e) {
      fail(name_, what + ": tree " + std::to_string(i) + ": " + e.what());
    }
  }
  converted_.push_back(std::move(packed));
  return converted_.back().view();
}

std::size_t QtFile::stored_tree_bytes() const {
  const fb::TreeSet* set = fb::GetFile(buffer())->trees();
  // Elements of `size` bytes (vectors of structs hand out pointers, not the structs' size).
  auto bytes = [](const auto* vector, std::size_t size) {
    return vector ? std::size_t(vector->size()) * size : 0;
  };
  if (version_ < 3)
    return bytes(set->extents(), sizeof(fb::TreeExtent)) + bytes(set->nodes(), sizeof(fb::Quad)) +
           bytes(set->errors(), sizeof(fb::Quad));
  return bytes(set->words(), sizeof(std::uint32_t)) +
         bytes(set->node_extents(), sizeof(fb::NodeExtent)) +
         bytes(set->packed_extents(), sizeof(fb::PackedExtent));
}

std::string QtFile::brdf_model() const {
  const auto* table = fb::GetFile(buffer())->brdf_table();
  return table && table->model() ? table->model()->str() : std::string();
}

std::string QtFile::brdf_spec() const {
  const auto* table = fb::GetFile(buffer())->brdf_table();
  return table && table->spec() ? table->spec()->str() : std::string();
}

CaptureSetView QtFile::captures() const {
  if (kind_ != QtKind::capture_set)
    fail(name_, std::string("holds a ") + to_string(kind_) + ", not a capture set");
  return captures_;
}

Provenance QtFile::provenance() const {
  Provenance p;
  const fb::Provenance* fp = fb::GetFile(buffer())->provenance();
  if (!fp) return p;
  if (fp->tool()) p.tool = fp->tool()->str();
  if (fp->tool_version()) p.tool_version = fp->tool_version()->str();
  if (fp->parameters()) p.parameters = fp->parameters()->str();
  if (fp->sources())
    for (const auto* s : *fp->sources())
      p.sources.push_back(s->str());
  return p;
}

namespace {

flatbuffers::Offset<fb::TreeSet> build_tree_set(flatbuffers::FlatBufferBuilder& b,
                                                const TreeSetView& trees,
                                                const ProjectionOptions& projection) {
  const PackedShape& s = trees.shape();
  // Sets of shared-exponent values: each tree's derived values made current, so that reading
  // gives back these trees, and left out.
  std::span<const TreeExtent> extents_written = trees.extents();
  std::span<const std::uint32_t> words_written = trees.words();
  std::vector<TreeExtent> elided_extents;
  std::vector<std::uint32_t> elided_words;
  const bool elide = has_derived_values(s);
  if (elide) {
    for (std::size_t i = 0; i < trees.size(); ++i) {
      const PackedTreeView tree = trees.tree(i);
      PackedTree current{s,
                         tree.scales(),
                         {tree.words().begin(), tree.words().end()},
                         std::size_t(tree.texel_start()),
                         tree.derived_rounding()};
      derive_refined_values(current);
      const std::vector<std::uint32_t> words = elide_refined_values(current.view());
      elided_extents.push_back({std::uint32_t(elided_words.size()),
                                std::uint32_t(current.node_count()),
                                std::uint32_t(current.texel_start), current.scales});
      elided_words.insert(elided_words.end(), words.begin(), words.end());
    }
    extents_written = elided_extents;
    words_written = elided_words;
  }
  const auto extents = b.CreateVectorOfStructs(
      reinterpret_cast<const fb::NodeExtent*>(extents_written.data()), extents_written.size());
  const auto words = b.CreateVector(words_written.data(), words_written.size());
  fb::TreeSetBuilder set(b);
  set.add_resolution(s.resolution);
  set.add_channels(s.channels);
  set.add_groups(s.groups);
  set.add_tolerance(projection.tolerance);
  set.add_tolerance_mode(projection.mode == ProjectionOptions::Mode::relative
                             ? fb::ToleranceMode::Relative
                             : fb::ToleranceMode::Absolute);
  set.add_max_depth(projection.max_depth);
  set.add_tolerance_floor(projection.local_floor);
  set.add_bounds(s.bounds == BoundKind::l2 ? fb::BoundKind::L2 : fb::BoundKind::Linf);
  set.add_bounded_groups(s.bounded_groups);
  set.add_node_extents(extents);
  set.add_exact_texels(s.exact_texels);
  set.add_value_encoding(s.value_encoding == ValueEncoding::shared_exponent
                             ? fb::ValueEncoding::SharedExponent
                             : fb::ValueEncoding::Halves);
  set.add_refined_values_elided(elide);
  set.add_words(words);
  return set.Finish();
}

flatbuffers::Offset<fb::Provenance> build_provenance(flatbuffers::FlatBufferBuilder& b,
                                                     const Provenance& p) {
  std::vector<flatbuffers::Offset<flatbuffers::String>> sources;
  for (const std::string& s : p.sources)
    sources.push_back(b.CreateString(s));
  return fb::CreateProvenance(b, b.CreateString(p.tool), b.CreateString(p.tool_version),
                              b.CreateString(p.parameters), b.CreateVector(sources));
}

std::vector<std::byte> finish(flatbuffers::FlatBufferBuilder& b, fb::Kind kind,
                              flatbuffers::Offset<fb::TreeSet> trees,
                              flatbuffers::Offset<fb::BrdfTable> table,
                              flatbuffers::Offset<fb::CaptureSet> captures,
                              flatbuffers::Offset<fb::Provenance> provenance) {
  const fb::Checksum unsealed;
  const auto root = fb::CreateFile(b, kQtFormatVersion, kind, fb::Mapping::CosineConcentric, trees,
                                   table, captures, provenance, &unsealed);
  fb::FinishFileBuffer(b, root);
  const auto* data = reinterpret_cast<const std::byte*>(b.GetBufferPointer());
  std::vector<std::byte> bytes(data, data + b.GetSize());
  try {
    if (!seal_qt_checksum(bytes)) throw FileError("the encoded file: cannot seal its checksum");
    QtFile::verify_bytes(bytes, "the encoded file");
  } catch (const FileError& e) {
    throw std::invalid_argument(std::string("refusing to write what the reader refuses: ") +
                                e.what());
  }
  return bytes;
}

void check_encodable(const TreeSetView& trees) {
  if (trees.size() == 0) throw std::invalid_argument("nothing to encode: no trees");
  if (trees.bytes() > kQtMaxFileBytes)
    throw std::invalid_argument("trees exceed the 2 GiB limit of one .qt file");
}

}  // namespace

std::vector<std::byte> encode_tree(const PackedTreeView& tree, const ProjectionOptions& projection,
                                   const Provenance& provenance) {
  const TreeExtent extent{0, std::uint32_t(tree.node_count()), std::uint32_t(tree.texel_start()),
                          tree.scales()};
  const TreeSetView set(tree.shape(), {&extent, 1}, tree.words());
  check_encodable(set);
  flatbuffers::FlatBufferBuilder b(set.bytes() + 1024);
  const auto trees = build_tree_set(b, set, projection);
  const auto prov = build_provenance(b, provenance);
  return finish(b, fb::Kind::Tree, trees, 0, 0, prov);
}

std::vector<std::byte> encode_brdf_table(const BrdfTableView& table, const std::string& model,
                                         const std::string& spec,
                                         const ProjectionOptions& projection,
                                         const Provenance& provenance) {
  check_encodable(table.trees);
  if (table.trees.shape().exact_texels)
    throw std::invalid_argument(
        "BRDF table entries marked as exact texels, which only captures hold");
  if (table.trees.size() != std::size_t(table.wo_resolution) * table.wo_resolution)
    throw std::invalid_argument("BRDF table entries do not match its resolution");
  if (table.has_tilt() && table.tilt.size() != table.trees.size())
    throw std::invalid_argument("BRDF table tilt trees do not match its entries");
  flatbuffers::FlatBufferBuilder b(table.trees.bytes() + table.tilt.bytes() + 4096);
  const auto trees = build_tree_set(b, table.trees, projection);
  flatbuffers::Offset<fb::TreeSet> tilt = 0;
  if (table.has_tilt()) tilt = build_tree_set(b, table.tilt, projection);
  const auto info = fb::CreateBrdfTable(b, table.wo_resolution, b.CreateString(model),
                                        b.CreateString(spec), tilt);
  const auto prov = build_provenance(b, provenance);
  return finish(b, fb::Kind::BrdfTable, trees, info, 0, prov);
}

std::vector<std::byte> encode_capture_set(const CaptureSetView& captures,
                                          const ProjectionOptions& projection,
                                          const Provenance& provenance) {
  check_encodable(captures.trees);
  if (captures.positions.size() != captures.trees.size() ||
      captures.normals.size() != captures.trees.size() ||
      captures.tangents.size() != captures.trees.size())
    throw std::invalid_argument("capture positions, normals and tangents do not match the trees");
  const auto& offsets = captures.light_offsets;
  if (!captures.lights.empty() && offsets.empty())
    throw std::invalid_argument("capture lights without offsets saying whose they are");
  if (!offsets.empty() &&
      (offsets.size() != captures.size() + 1 || offsets.front() != 0 ||
       offsets.back() != captures.lights.size() || !std::is_sorted(offsets.begin(), offsets.end())))
    throw std::invalid_argument("capture light offsets do not match the captures and lights");
  flatbuffers::FlatBufferBuilder b(captures.trees.bytes() + captures.size() * 3 * sizeof(Vec3) +
                                   captures.lights.size_bytes() +
                                   captures.light_offsets.size_bytes() + 4096);
  const auto trees = build_tree_set(b, captures.trees, projection);
  auto points = [&](std::span<const Vec3> v) {
    return b.CreateVectorOfStructs(reinterpret_cast<const fb::Vec3*>(v.data()), v.size());
  };
  const auto positions = points(captures.positions);
  const auto normals = points(captures.normals);
  const auto tangents = points(captures.tangents);
  flatbuffers::Offset<flatbuffers::Vector<const fb::Light*>> lights = 0;
  flatbuffers::Offset<flatbuffers::Vector<std::uint32_t>> light_offsets = 0;
  if (!captures.lights.empty()) {
    lights = b.CreateVectorOfStructs(reinterpret_cast<const fb::Light*>(captures.lights.data()),
                                     captures.lights.size());
    light_offsets = b.CreateVector(captures.light_offsets.data(), captures.light_offsets.size());
  }
  const auto info = fb::CreateCaptureSet(b, positions, normals, tangents, lights, light_offsets);
  const auto prov = build_provenance(b, provenance);
  return finish(b, fb::Kind::CaptureSet, trees, 0, info, prov);
}

bool seal_qt_checksum(std::span<std::byte> bytes) {
  const auto* data = reinterpret_cast<const std::uint8_t*>(bytes.data());
  if (bytes.size() < 8 || bytes.size() > kQtMaxFileBytes || !fb::FileBufferHasIdentifier(data))
    return false;
  flatbuffers::Verifier verifier(data, bytes.size());
  if (!fb::VerifyFileBuffer(verifier)) return false;
  const fb::Checksum* stored = fb::GetFile(data)->checksum();
  if (!stored) return false;
  const std::size_t at = checksum_offset(data, *stored);
  const std::array<std::byte, 16> sum = expected_checksum(bytes, at);
  std::memcpy(bytes.data() + at, sum.data(), sum.size());
  return true;
}

void write_qt(const std::string& path, std::span<const std::byte> encoded) {
  write_file_atomically(path, encoded);
}

}  // namespace basis
