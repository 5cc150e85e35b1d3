// The .qt format: round trips keep bits and convolution results; corrupt, truncated, foreign
// and future files are rejected with one clear line; writes are atomic.
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "basis/core/convolution.h"
#include "basis/core/projection.h"
#include "basis/core/refined_values.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_recipe.h"
#include "basis/lighting/capture.h"
#include "basis_generated.h"
#include "support/environments.h"
#include "support/temp_dir.h"
#include "support/test_functions.h"

namespace basis {
namespace {

namespace fs = std::filesystem;

using testing::TempDir;

Provenance test_provenance() {
  return {"format_test", "1", R"({"seed": 1})", {"a.json", "b.exr"}};
}

Quadtree sample_float_tree(int n, int channels, int which, double tolerance = 0.05) {
  return project(testing::test_functions(n, channels, 17)[which].grid, {.tolerance = tolerance});
}

PackedTree sample_tree(int n, int channels, int which, double tolerance = 0.05) {
  return pack(sample_float_tree(n, channels, which, tolerance));
}

TreeSet sample_set(int count, int n, int channels) {
  TreeSet set(PackedShape{n, channels, 1, BoundKind::l2});
  for (int i = 0; i < count; ++i)
    set.append(sample_tree(n, channels, i % 6, 0.01 + 0.02 * i).view());
  return set;
}

CaptureSet sample_captures(int count) {
  CaptureSet c;
  c.trees = sample_set(count, 32, 3);
  for (int i = 0; i < count; ++i) {
    c.positions.push_back({double(i), 2.5, -1e3});
    const double a = 0.3 * i;
    c.normals.push_back({std::sin(a), 0, std::cos(a)});
    c.tangents.push_back({std::cos(a), 0, -std::sin(a)});
    // Every other capture sees i % 3 lights (a sun kept apart), the rest none.
    c.light_offsets.push_back(std::uint32_t(c.lights.size()));
    for (int l = 0; l < (i % 2 ? i % 3 : 0); ++l) {
      const double t = 0.2 + 0.3 * l;
      c.lights.push_back({{std::sin(t), 0, std::cos(t)}, {1e3 * (i + 1), 2e3, 5.0 * l}});
    }
  }
  c.light_offsets.push_back(std::uint32_t(c.lights.size()));
  return c;
}

// Captures as capture2qt makes them: exact texels in shared-exponent words, with many nodes
// refined over all four quadrants (random texels, smooth light).
CaptureSet exact_captures(int count) {
  CaptureSet c = sample_captures(count);
  c.trees = TreeSet();
  for (int i = 0; i < count; ++i) {
    const PackedTree tree = pack_exact_texels(sample_float_tree(32, 3, i % 2, 0.01 * i));
    if (i == 0) c.trees = TreeSet(tree.shape);
    c.trees.append(tree.view());
  }
  return c;
}

BrdfTable sample_table(int m) {
  BrdfTable t;
  t.wo_resolution = m;
  t.trees = TreeSet(PackedShape{16, 1, 1, BoundKind::l2});
  t.tilt = TreeSet(PackedShape{16, 1, 2, BoundKind::l2});
  for (int k = 0; k < m * m; ++k) {
    std::mt19937 rng(k);
    std::uniform_real_distribution<float> unit(0, 1);
    Grid g(16, 1, 1), d(16, 1, 2);
    for (float& v : g.texels)
      v = unit(rng) * (k % 3 == 0 ? 0.01f : 1.0f);
    for (float& v : d.texels)
      v = unit(rng) - 0.5f;
    t.trees.append(pack(project(g, {.tolerance = 0.1})).view());
    t.tilt.append(pack(project(d, {.tolerance = 0.1})).view());
  }
  t.model = "phong";
  t.spec = R"({"model": "phong", "exponent": 100})";
  return t;
}

bool same_words(std::span<const std::uint32_t> a, std::span<const std::uint32_t> b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size_bytes()) == 0;
}

std::vector<std::byte> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> chars((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<std::byte> bytes(chars.size());
  std::memcpy(bytes.data(), chars.data(), chars.size());
  return bytes;
}

void write_bytes(const std::string& path, std::span<const std::byte> bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

std::string load_error(std::span<const std::byte> bytes) {
  try {
    QtFile::from_bytes(bytes, "input.qt");
  } catch (const FileError& e) {
    return e.what();
  }
  return "";
}

// The extent of a tree alone in its set.
TreeExtent whole_tree(const PackedTree& tree) {
  return {0, std::uint32_t(tree.node_count()), std::uint32_t(tree.texel_start), tree.scales};
}

// The bytes of a tree or a capture set written with the schema alone, without the library
// writer's checks (as a damaged or foreign writer could), at the current version; from version
// 8 on with their checksum sealed, so that the reader's other checks are what they meet.
std::vector<std::byte> unchecked_file(const TreeSetView& trees, const CaptureSetView* captures,
                                      std::uint8_t bound_kind = 0,
                                      std::uint32_t version = kQtFormatVersion,
                                      int bounded_groups = 1, int value_encoding = -1,
                                      bool refined_values_elided = false) {
  flatbuffers::FlatBufferBuilder b;
  auto structs = [&]<typename F, typename T>(std::span<const T> v) {
    return b.CreateVectorOfStructs(reinterpret_cast<const F*>(v.data()), v.size());
  };
  const PackedShape& s = trees.shape();
  flatbuffers::Offset<flatbuffers::Vector<const format::NodeExtent*>> node_extents = 0;
  flatbuffers::Offset<flatbuffers::Vector<const format::PackedExtent*>> packed_extents = 0;
  if (version >= 5) {
    node_extents = structs.operator()<format::NodeExtent>(trees.extents());
  } else {  // versions 3 and 4: extents in nodes, all of them full
    std::vector<format::PackedExtent> old;
    for (const TreeExtent& e : trees.extents())
      old.emplace_back(e.first_word / std::uint32_t(s.words_per_node()), e.node_count,
                       e.scales.value_scale, e.scales.bound_scale);
    packed_extents = b.CreateVectorOfStructs(old);
  }
  const auto words = b.CreateVector(trees.words().data(), trees.words().size());
  format::TreeSetBuilder set(b);
  set.add_resolution(s.resolution);
  set.add_channels(s.channels);
  set.add_groups(s.groups);
  set.add_tolerance(0.05);
  set.add_bounds(format::BoundKind(bound_kind));
  if (version >= 4) set.add_bounded_groups(bounded_groups);  // version 3 had no such field
  if (version >= 5) {
    set.add_node_extents(node_extents);
    set.add_exact_texels(s.exact_texels);
  } else {
    set.add_packed_extents(packed_extents);
  }
  if (version >= 6)  // the shape's encoding unless told otherwise
    set.add_value_encoding(
        format::ValueEncoding(value_encoding >= 0 ? value_encoding : int(s.value_encoding)));
  if (refined_values_elided) set.add_refined_values_elided(true);
  set.add_words(words);
  const auto set_offset = set.Finish();
  flatbuffers::Offset<format::CaptureSet> info = 0;
  if (captures)
    info = format::CreateCaptureSet(
        b, structs.operator()<format::Vec3>(captures->positions),
        structs.operator()<format::Vec3>(captures->normals),
        structs.operator()<format::Vec3>(captures->tangents),
        structs.operator()<format::Light>(captures->lights),
        b.CreateVector(captures->light_offsets.data(), captures->light_offsets.size()));
  const format::Checksum unsealed;
  const auto root =
      format::CreateFile(b, version, captures ? format::Kind::CaptureSet : format::Kind::Tree,
                         format::Mapping::CosineConcentric, set_offset, 0, info, 0,
                         version >= 8 ? &unsealed : nullptr);
  format::FinishFileBuffer(b, root);
  const auto* data = reinterpret_cast<const std::byte*>(b.GetBufferPointer());
  std::vector<std::byte> bytes(data, data + b.GetSize());
  if (version >= 8 && !seal_qt_checksum(bytes))
    throw std::logic_error("unchecked_file: the schema's buffer did not take its checksum");
  return bytes;
}

// A file of version 1 or 2 (float trees: 16-byte quads of links, values and error bounds).
std::vector<std::byte> old_version_file(const Quadtree& tree, std::uint32_t version) {
  flatbuffers::FlatBufferBuilder b;
  const format::TreeExtent extent(0, std::uint32_t(tree.node_count()));
  const auto trees = format::CreateTreeSet(
      b, tree.shape.resolution, tree.shape.channels, tree.shape.groups, 0.05,
      format::ToleranceMode::Relative, 0, b.CreateVectorOfStructs(&extent, 1),
      b.CreateVectorOfStructs(reinterpret_cast<const format::Quad*>(tree.nodes.data()),
                              tree.nodes.size()),
      b.CreateVectorOfStructs(reinterpret_cast<const format::Quad*>(tree.errors.data()),
                              tree.errors.size()));
  const auto root =
      format::CreateFile(b, version, format::Kind::Tree, format::Mapping::CosineConcentric, trees);
  format::FinishFileBuffer(b, root);
  const auto* data = reinterpret_cast<const std::byte*>(b.GetBufferPointer());
  return {data, data + b.GetSize()};
}

// The loader's error for content written without checks, after checking that the library's
// encoder refuses the same content for the same problem (and accepts what the loader accepts).
template <typename Encode>
std::string refused(const std::vector<std::byte>& unchecked, const Encode& encode) {
  const std::string error = load_error(unchecked);
  try {
    encode();
    EXPECT_EQ(error, "") << "the encoder wrote what the loader refuses";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(error, "") << "the encoder refused what the loader accepts: " << e.what();
    const std::string problem = error.substr(error.find(": ") + 2);
    EXPECT_NE(std::string(e.what()).find(problem), std::string::npos)
        << e.what() << " against " << error;
  }
  return error;
}

TEST(QtFormat, TreeRoundTripKeepsBitsAndConvolution) {
  TempDir dir;
  const PackedTree tree = sample_tree(64, 3, 1);
  const ProjectionOptions projection{.tolerance = 0.05, .max_depth = 5};
  write_qt(dir.file("tree.qt"), encode_tree(tree.view(), projection, test_provenance()));
  const QtFile file = QtFile::load(dir.file("tree.qt"));
  EXPECT_EQ(file.kind(), QtKind::tree);
  EXPECT_EQ(file.format_version(), kQtFormatVersion);
  EXPECT_TRUE(same_words(file.tree().words(), tree.words));
  EXPECT_EQ(file.tree().shape(), tree.shape);
  EXPECT_EQ(file.tree().scales(), tree.scales);
  EXPECT_EQ(file.projection().tolerance, 0.05);
  EXPECT_EQ(file.projection().max_depth, 5);
  // Zero copy: the loaded tree's nodes live inside the file's memory map, word aligned.
  EXPECT_TRUE(file.zero_copy());
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(file.tree().words().data()) % 4, 0u);
  const PackedTree other = sample_tree(32, 3, 2);
  const Convolution a = convolve(tree.view(), other.view());
  const Convolution b = convolve(file.tree(), other.view());
  EXPECT_EQ(a.value, b.value);
  EXPECT_EQ(a.bound, b.bound);
  const Provenance p = file.provenance();
  EXPECT_EQ(p.tool, "format_test");
  EXPECT_EQ(p.parameters, R"({"seed": 1})");
  EXPECT_EQ(p.sources, (std::vector<std::string>{"a.json", "b.exr"}));
  // Encoding is deterministic: the same input gives the same bytes.
  EXPECT_EQ(read_bytes(dir.file("tree.qt")),
            encode_tree(file.tree(), file.projection(), file.provenance()));
}

// Files of versions 1 and 2 hold float trees: they load, packed with their error bounds, to
// the same trees as packing the float trees directly.
TEST(QtFormat, OlderVersionsLoadPackedWithTheirErrorBounds) {
  const Quadtree tree = sample_float_tree(32, 3, 1);
  const PackedTree expected = pack(tree, BoundKind::linf);
  for (const std::uint32_t version : {1u, 2u}) {
    const QtFile file = QtFile::from_bytes(old_version_file(tree, version), "old.qt");
    EXPECT_EQ(file.format_version(), version);
    EXPECT_FALSE(file.zero_copy());
    EXPECT_EQ(file.tree().shape(), expected.shape);
    EXPECT_EQ(file.tree().scales(), expected.scales);
    EXPECT_TRUE(same_words(file.tree().words(), expected.words));
  }
}

TEST(QtFormat, BrdfTableRoundTrip) {
  TempDir dir;
  const BrdfTable table = sample_table(4);
  write_qt(dir.file("t.qt"),
           encode_brdf_table(table.view(), table.model, table.spec, {}, test_provenance()));
  const QtFile file = QtFile::load(dir.file("t.qt"));
  ASSERT_EQ(file.kind(), QtKind::brdf_table);
  const BrdfTableView loaded = file.brdf_table();
  EXPECT_EQ(loaded.wo_resolution, 4);
  EXPECT_EQ(file.brdf_model(), "phong");
  EXPECT_EQ(file.brdf_spec(), table.spec);
  EXPECT_TRUE(same_words(loaded.trees.words(), table.trees.view().words()));
  const PackedTree light = sample_tree(16, 1, 0);
  ASSERT_TRUE(loaded.has_tilt());
  EXPECT_TRUE(same_words(loaded.tilt.words(), table.tilt.view().words()));
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(convolve(loaded.entry(i, j), light.view()).value,
                convolve(table.view().entry(i, j), light.view()).value);
      EXPECT_EQ(convolve_groups(loaded.tilt_entry(i, j), light.view()).value,
                convolve_groups(table.view().tilt_entry(i, j), light.view()).value);
    }
  EXPECT_THROW(file.captures(), FileError);
}

TEST(QtFormat, CaptureSetRoundTrip) {
  TempDir dir;
  const CaptureSet captures = sample_captures(12);
  write_qt(dir.file("c.qt"), encode_capture_set(captures.view(), {}, test_provenance()));
  const QtFile file = QtFile::load(dir.file("c.qt"));
  ASSERT_EQ(file.kind(), QtKind::capture_set);
  EXPECT_EQ(file.format_version(), kQtFormatVersion);
  const CaptureSetView loaded = file.captures();
  ASSERT_EQ(loaded.size(), 12u);
  for (std::size_t i = 0; i < 12; ++i) {
    EXPECT_EQ(loaded.positions[i], captures.positions[i]);
    EXPECT_EQ(loaded.normals[i], captures.normals[i]);
    EXPECT_EQ(loaded.tangents[i], captures.tangents[i]);
    EXPECT_TRUE(same_words(loaded.trees.tree(i).words(), captures.trees.tree(i).words()));
    const Convolution a = convolve(loaded.trees.tree(i), loaded.trees.tree((i + 1) % 12));
    const Convolution b = convolve(captures.trees.tree(i), captures.trees.tree((i + 1) % 12));
    EXPECT_EQ(a.value, b.value);
    const auto lights = loaded.lights_of(i), expected = captures.view().lights_of(i);
    ASSERT_EQ(lights.size(), expected.size()) << i;
    for (std::size_t l = 0; l < lights.size(); ++l) {
      EXPECT_EQ(lights[l].direction, expected[l].direction);
      EXPECT_EQ(lights[l].energy, expected[l].energy);
    }
  }
  EXPECT_GT(loaded.lights.size(), 0u);
  EXPECT_THROW(file.brdf_table(), FileError);
  // A set without lights stays without.
  CaptureSet unlit = sample_captures(2);
  unlit.lights.clear();
  unlit.light_offsets.clear();
  const QtFile plain = QtFile::from_bytes(encode_capture_set(unlit.view(), {}, {}), "plain.qt");
  EXPECT_TRUE(plain.captures().light_offsets.empty());
  EXPECT_TRUE(plain.captures().lights_of(1).empty());
}

TEST(QtFormat, BadCaptureLightsAreNamedAndNeverWritten) {
  auto error_of = [](const CaptureSet& c) {
    const CaptureSetView view = c.view();
    return refused(unchecked_file(view.trees, &view), [&] { encode_capture_set(view, {}, {}); });
  };
  const CaptureSet good = sample_captures(6);
  ASSERT_EQ(error_of(good), "");
  ASSERT_GE(good.lights.size(), 2u);
  CaptureSet below = good;
  below.lights[0].direction = {0, std::sin(0.1), -std::cos(0.1)};
  EXPECT_NE(error_of(below).find("capture light 0"), std::string::npos);
  CaptureSet long_direction = good;
  long_direction.lights[1].direction = {0, 0, 2};
  EXPECT_NE(error_of(long_direction).find("capture light 1"), std::string::npos);
  CaptureSet nan = good;
  nan.lights[1].energy[2] = std::nan("");
  EXPECT_NE(error_of(nan).find("energy negative or not finite"), std::string::npos);
  CaptureSet negative = good;
  negative.lights[0].energy[0] = -1;
  EXPECT_NE(error_of(negative).find("energy negative or not finite"), std::string::npos);
  // Offsets out of order: the encoder refuses them, and so does the reader of bytes changed
  // after encoding (the offsets found by their values in the buffer).
  ASSERT_EQ(good.light_offsets, (std::vector<std::uint32_t>{0, 0, 1, 1, 1, 1, 3}));
  CaptureSet unsorted = good;
  unsorted.light_offsets[1] = 2;
  EXPECT_THROW(encode_capture_set(unsorted.view(), {}, {}), std::invalid_argument);
  std::vector<std::byte> bytes = encode_capture_set(good.view(), {}, {});
  const auto* offsets = reinterpret_cast<const std::byte*>(good.light_offsets.data());
  const auto at = std::search(bytes.begin(), bytes.end(), offsets, offsets + 7 * 4);
  ASSERT_NE(at, bytes.end());
  const std::uint32_t two = 2;
  std::memcpy(&*at + 4, &two, 4);
  EXPECT_NE(load_error(bytes).find("checksum mismatch"), std::string::npos);
  ASSERT_TRUE(seal_qt_checksum(bytes));  // as a writer that checks nothing would leave it
  EXPECT_NE(load_error(bytes).find("light offsets"), std::string::npos);
  CaptureSet short_offsets = good;
  short_offsets.light_offsets.pop_back();
  EXPECT_THROW(encode_capture_set(short_offsets.view(), {}, {}), std::invalid_argument);
  CaptureSet no_offsets = good;
  no_offsets.light_offsets.clear();
  EXPECT_THROW(encode_capture_set(no_offsets.view(), {}, {}), std::invalid_argument);
}

// Every mutated or truncated buffer is refused with one line. Sealed again (as a
// writer that checks nothing would leave it), it either loads as a valid file, whose trees then
// convolve to finite values, or is rejected with a FileError; nothing else happens.
TEST(QtFormat, MutatedAndTruncatedFilesLoadValidOrFailCleanly) {
  const std::vector<std::vector<std::byte>> originals = {
      encode_tree(sample_tree(32, 3, 1).view(), {}, test_provenance()),
      encode_brdf_table(sample_table(2).view(), "phong", "{}", {}, test_provenance()),
      encode_capture_set(sample_captures(3).view(), {}, test_provenance()),
      encode_capture_set(exact_captures(3).view(), {}, test_provenance())};
  const PackedTree probe = sample_tree(8, 1, 0);
  std::mt19937 rng(2024);
  int changed = 0, loaded = 0, rejected = 0;
  auto expect_one_line = [](const FileError& e) {
    ASSERT_EQ(std::string(e.what()).rfind("mutated.qt: ", 0), 0u) << e.what();
    ASSERT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  };
  for (int trial = 0; trial < 6000; ++trial) {
    const std::vector<std::byte>& original = originals[trial % originals.size()];
    std::vector<std::byte> bytes = original;
    std::uniform_int_distribution<std::size_t> position(0, bytes.size() - 1);
    switch (trial / originals.size() % 4) {  // every kind of mutation for every original
      case 0:                                // truncate
        bytes.resize(position(rng));
        break;
      case 1:  // flip a few bits
        for (int k = 0; k < 1 + trial % 5; ++k)
          bytes[position(rng)] ^= std::byte(1 << (rng() % 8));
        break;
      case 2:  // overwrite a run with random bytes
        for (std::size_t p = position(rng), k = 0; k < 16 && p + k < bytes.size(); ++k)
          bytes[p + k] = std::byte(rng());
        break;
      default:  // set a random 32-bit word to an extreme value
        if (bytes.size() >= 8) {
          const std::size_t p = position(rng) & ~std::size_t(3);
          const std::uint32_t extremes[] = {0,           0xffffffffu, 0x7fffffffu,
                                            0x80000000u, 1,           0x7fc00000u};
          if (p + 4 <= bytes.size()) std::memcpy(&bytes[p], &extremes[rng() % 6], 4);
        }
    }
    if (bytes != original) {
      ++changed;
      try {
        QtFile::from_bytes(bytes, "mutated.qt");
        FAIL() << "a changed file loaded (trial " << trial << ")";
      } catch (const FileError& e) {
        expect_one_line(e);
      }
    }
    seal_qt_checksum(bytes);  // where the structure still holds the field
    try {
      const QtFile file = QtFile::from_bytes(bytes, "mutated.qt");
      ++loaded;
      for (std::size_t i = 0; i < file.trees().size(); ++i) {
        if (file.trees().shape().channels != 1 && file.trees().shape().channels != 3) FAIL();
        const Convolution c = convolve(file.trees().tree(i), probe.view());
        for (float v : c.value)
          ASSERT_FALSE(std::isnan(v));
      }
    } catch (const FileError& e) {
      ++rejected;
      expect_one_line(e);
    }
  }
  EXPECT_GT(changed, 5500);
  EXPECT_GT(rejected, 3000);
  EXPECT_GT(loaded, 300);  // mutations of values that stay valid once sealed
}

// Version 8 files carry the XXH3-128 of their own bytes (the field read as zeros); any byte
// changed, added or cut is refused, values included, which no structural check can see. Files of
// earlier versions carry none and still load.
TEST(QtFormat, ChecksumRefusesEveryChangedByte) {
  const std::vector<std::vector<std::byte>> files = {
      encode_tree(sample_tree(16, 3, 1).view(), {}, test_provenance()),
      encode_brdf_table(sample_table(2).view(), "phong", "{}", {}, test_provenance()),
      encode_capture_set(exact_captures(2).view(), {}, test_provenance())};
  for (const std::vector<std::byte>& file : files) {
    const auto* root = format::GetFile(file.data());
    ASSERT_NE(root->checksum(), nullptr);
    const auto* field = reinterpret_cast<const std::byte*>(root->checksum()->bytes()->Data());
    const std::size_t at = std::size_t(field - file.data());
    // The stored bytes are the canonical XXH3-128 of the file with them zeroed, as xxh128sum
    // prints it.
    std::vector<std::byte> zeroed = file;
    std::fill_n(zeroed.begin() + std::ptrdiff_t(at), 16, std::byte{0});
    std::string stored;
    for (int k = 0; k < 16; ++k) {
      static constexpr char kHex[] = "0123456789abcdef";
      stored += kHex[unsigned(file[at + k]) >> 4];
      stored += kHex[unsigned(file[at + k]) & 15];
    }
    TempDir dir;
    const std::string zeroed_path = dir.path() + "/zeroed.qt";
    std::ofstream(zeroed_path, std::ios::binary)
        .write(reinterpret_cast<const char*>(zeroed.data()), std::streamsize(zeroed.size()));
    ASSERT_EQ(::system(("xxh128sum '" + zeroed_path + "' > '" + zeroed_path + ".sum'").c_str()), 0);
    std::string printed;
    std::ifstream(zeroed_path + ".sum") >> printed;
    EXPECT_EQ(stored, printed);
    EXPECT_TRUE(QtFile::from_bytes(file, "input.qt").checksum_verified());

    // Every byte changed, one at a time: refused; in the trees' words with the checksum's
    // words.
    const auto* words = root->trees()->words();
    const std::size_t words_at =
        std::size_t(reinterpret_cast<const std::byte*>(words->Data()) - file.data());
    const std::size_t words_end = words_at + words->size() * sizeof(std::uint32_t);
    int in_words = 0;
    for (std::size_t p = 0; p < file.size(); ++p) {
      std::vector<std::byte> changed = file;
      changed[p] ^= std::byte{0x10};
      const std::string error = load_error(changed);
      ASSERT_EQ(error.rfind("input.qt: ", 0), 0u) << "byte " << p << " changed, loaded";
      if (p >= words_at && p < words_end) {
        ++in_words;
        EXPECT_NE(error.find("checksum mismatch"), std::string::npos) << error;
      }
    }
    EXPECT_GT(in_words, 100);
    // A version changed to an earlier one, which had no checksum, does not turn the check off.
    const auto* version_field = reinterpret_cast<const flatbuffers::Table*>(root)->GetAddressOf(
        format::File::VT_FORMAT_VERSION);
    ASSERT_NE(version_field, nullptr);
    const std::size_t version_at =
        std::size_t(reinterpret_cast<const std::byte*>(version_field) - file.data());
    for (std::uint32_t earlier = 1; earlier < 8; ++earlier) {
      std::vector<std::byte> downgraded = file;
      std::memcpy(downgraded.data() + version_at, &earlier, 4);
      EXPECT_NE(load_error(downgraded).find("checksum mismatch"), std::string::npos) << earlier;
    }
    std::vector<std::byte> longer = file;
    longer.push_back(std::byte{0});
    EXPECT_NE(load_error(longer).find("checksum mismatch"), std::string::npos);
    EXPECT_NE(load_error({file.data(), file.size() - 1}), "");
  }

  // A version 8 file without the field is refused; version 7, which had none, loads.
  const PackedTree tree = sample_tree(8, 3, 1);
  const TreeExtent extent = whole_tree(tree);
  const TreeSetView set(tree.shape, {&extent, 1}, tree.words);
  {
    flatbuffers::FlatBufferBuilder b;
    const auto words = b.CreateVector(set.words().data(), set.words().size());
    const auto extents = b.CreateVectorOfStructs(
        reinterpret_cast<const format::NodeExtent*>(set.extents().data()), set.extents().size());
    format::TreeSetBuilder trees(b);
    trees.add_resolution(tree.shape.resolution);
    trees.add_channels(tree.shape.channels);
    trees.add_groups(tree.shape.groups);
    trees.add_node_extents(extents);
    trees.add_words(words);
    const auto trees_offset = trees.Finish();
    format::FinishFileBuffer(
        b, format::CreateFile(b, 8, format::Kind::Tree, format::Mapping::CosineConcentric,
                              trees_offset));
    const auto* data = reinterpret_cast<const std::byte*>(b.GetBufferPointer());
    EXPECT_EQ(load_error({data, b.GetSize()}),
              "input.qt: no checksum, which format version 8 files carry (corrupt file)");
  }
  const std::vector<std::byte> version7 = unchecked_file(set, nullptr, 0, 7);
  EXPECT_EQ(load_error(version7), "");
  EXPECT_FALSE(QtFile::from_bytes(version7, "input.qt").checksum_verified());
}

TEST(QtFormat, ForeignEmptyAndFutureFilesAreRejected) {
  TempDir dir;
  // A file one byte past the largest buffer the FlatBuffers verifier takes, with the identifier
  // that leads to it, is refused by its size before it is mapped (a sparse file: no disk used).
  {
    const std::string huge = dir.path() + "/huge.qt";
    std::ofstream(huge, std::ios::binary) << std::string("\0\0\0\0BQTF", 8);
    std::filesystem::resize_file(huge, kQtMaxFileBytes + 1);
    ASSERT_EQ(kQtMaxFileBytes + 1, (std::uint64_t(1) << 31) - 1);
    try {
      QtFile::load(huge);
      ADD_FAILURE() << "a file past the format's limit loaded";
    } catch (const FileError& e) {
      EXPECT_EQ(std::string(e.what()),
                huge + ": file of 2147483647 bytes exceeds the 2 GiB format limit");
    }
  }
  EXPECT_EQ(load_error({}), "input.qt: empty file, not a .qt file");
  const std::string png = "\x89PNG\r\n\x1a\n\0\0\0\rIHDR";
  EXPECT_EQ(load_error(std::as_bytes(std::span(png.data(), png.size()))),
            "input.qt: not a .qt file (no BQTF identifier)");
  const std::string text = "model: phong, exponent: 100\n";
  EXPECT_EQ(load_error(std::as_bytes(std::span(text.data(), text.size()))),
            "input.qt: not a .qt file (no BQTF identifier)");

  // Another FlatBuffers file: the same schema under a different identifier.
  {
    flatbuffers::FlatBufferBuilder b;
    const auto root = format::CreateFile(b, 1);
    b.Finish(root, "XXXX");
    EXPECT_EQ(load_error({reinterpret_cast<const std::byte*>(b.GetBufferPointer()), b.GetSize()}),
              "input.qt: not a .qt file (no BQTF identifier)");
  }
  // Versions 1 and 2 (float trees) and 3 read; a future version, otherwise well formed, is
  // refused by name.
  const Quadtree old = sample_float_tree(8, 1, 0);
  for (const std::uint32_t version : {1u, 2u})
    EXPECT_EQ(load_error(old_version_file(old, version)), "");
  const PackedTree tree = sample_tree(8, 1, 0);
  const TreeExtent extent = whole_tree(tree);
  const TreeSetView set(tree.shape, {&extent, 1}, tree.words);
  EXPECT_EQ(load_error(unchecked_file(set, nullptr)), "");
  std::vector<std::byte> future = unchecked_file(set, nullptr);
  {
    flatbuffers::FlatBufferBuilder b;
    const auto words = b.CreateVector(tree.words.data(), tree.words.size());
    const auto extents =
        b.CreateVectorOfStructs(reinterpret_cast<const format::NodeExtent*>(&extent), 1);
    format::TreeSetBuilder sb(b);
    sb.add_resolution(8);
    sb.add_channels(1);
    sb.add_groups(1);
    sb.add_node_extents(extents);
    sb.add_words(words);
    const auto trees = sb.Finish();
    format::FinishFileBuffer(b, format::CreateFile(b, kQtFormatVersion + 1, format::Kind::Tree,
                                                   format::Mapping::CosineConcentric, trees));
    future.assign(reinterpret_cast<const std::byte*>(b.GetBufferPointer()),
                  reinterpret_cast<const std::byte*>(b.GetBufferPointer()) + b.GetSize());
  }
  EXPECT_EQ(load_error(future), "input.qt: format version " + std::to_string(kQtFormatVersion + 1) +
                                    " is newer than this build reads (" +
                                    std::to_string(kQtFormatVersion) + ")");
  EXPECT_THROW(QtFile::load(dir.file("missing.qt")), FileError);
  try {
    QtFile::load(dir.file("missing.qt"));
  } catch (const FileError& e) {
    EXPECT_EQ(std::string(e.what()), dir.file("missing.qt") + ": No such file or directory");
  }
  try {
    QtFile::load(dir.file(""));
    FAIL();
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos);
  }
  write_bytes(dir.file("empty.qt"), {});
  EXPECT_THROW(QtFile::load(dir.file("empty.qt")), FileError);
}

// Structurally valid buffers whose packed trees break the format's rules.
TEST(QtFormat, SemanticViolationsAreNamedAndNeverWritten) {
  auto with_link = [](PackedTree tree, int node, std::uint32_t link) {
    tree.words[std::size_t(node) * tree.shape.words_per_node()] = link;
    return tree;
  };
  auto error_of = [](const PackedTree& tree) {
    const TreeExtent extent = whole_tree(tree);
    const TreeSetView set(tree.shape, {&extent, 1}, tree.words);
    return refused(unchecked_file(set, nullptr), [&] { encode_tree(tree.view(), {}, {}); });
  };
  const PackedTree good = sample_tree(32, 1, 1);
  ASSERT_GT(good.node_count(), 3);
  ASSERT_EQ(error_of(good), "");
  const std::uint32_t root = good.view().link(0);
  ASSERT_NE(root, 0u);
  // The root's children start anywhere but right after it; past the tree's end.
  EXPECT_NE(error_of(with_link(good, 0, (root & 15u) | 2u << 4)).find("breadth first"),
            std::string::npos);
  EXPECT_NE(error_of(with_link(good, 0, (root & 15u) | 1000000u << 4)).find("links to node"),
            std::string::npos);
  // A node whose children nobody counts: unreachable.
  EXPECT_NE(error_of(with_link(good, 0, 0)).find("unreachable"), std::string::npos);
  // A chain deeper than a resolution of 8 allows (3 levels of nodes).
  PackedTree chain = pack(sample_float_tree(8, 1, 0, 0.0));
  chain.words.assign(std::size_t(4) * chain.shape.words_per_node(), 0);
  chain.texel_start = 4;
  for (int n = 0; n < 3; ++n)
    chain = with_link(chain, n, std::uint32_t(n + 1) << 4 | 1u);
  EXPECT_NE(error_of(chain).find("deeper than its resolution"), std::string::npos);
  // Values that are not numbers: a NaN half and an infinite one.
  for (const std::uint16_t bad : {std::uint16_t(0x7e00), std::uint16_t(0xfc00)}) {
    PackedTree nan = good;
    std::memcpy(reinterpret_cast<char*>(nan.words.data() + 1) + 2, &bad, 2);
    EXPECT_NE(error_of(nan).find("NaN or infinite"), std::string::npos);
  }
  // Scales that are not finite positive numbers.
  for (const float scale : {0.0f, -1.0f, INFINITY, std::nanf("")}) {
    PackedTree scaled = good;
    scaled.scales.bound_scale = scale;
    EXPECT_NE(error_of(scaled).find("scales"), std::string::npos) << scale;
  }
  // Scales no packing writes, under which a half (or a bound code) would decode to infinity,
  // and the largest it writes, accepted.
  for (const float scale : {0x1p111f, 0x1p126f, 3.0f, 0.75f}) {
    PackedTree scaled = good;
    scaled.scales.value_scale = scale;
    EXPECT_NE(error_of(scaled).find("value scale"), std::string::npos) << scale;
  }
  for (const float scale : {0x1p125f * 1.5f, 0x1p127f}) {
    PackedTree scaled = good;
    scaled.scales.bound_scale = scale;
    EXPECT_NE(error_of(scaled).find("bound scale"), std::string::npos) << scale;
  }
  PackedTree largest = good;
  largest.scales.value_scale = kLargestValueScale;
  largest.scales.bound_scale = kLargestBoundScale;
  EXPECT_EQ(error_of(largest), "");
  // Packing refuses what those scales cannot hold.
  Grid huge(8, 1);
  for (float& t : huge.texels)
    t = 0x1p125f;
  EXPECT_THROW(pack(project(huge)), std::overflow_error);
  // Values as small as subnormal floats pack with a scale that is not zero, and write.
  for (const float small : {1e-45f, 1e-40f, 1e-38f}) {
    Grid tiny(8, 1);
    for (float& t : tiny.texels)
      t = small;
    const PackedTree packed = pack(project(tiny));
    EXPECT_GT(packed.scales.value_scale, 0) << small;
    EXPECT_EQ(error_of(packed), "") << small;
  }
  // A bound kind no writer holds.
  const TreeExtent extent = whole_tree(good);
  EXPECT_EQ(
      load_error(unchecked_file(TreeSetView(good.shape, {&extent, 1}, good.words), nullptr, 7)),
      "input.qt: trees: unknown bound kind 7");
  // Bounds claimed for more groups than the trees hold, or none.
  for (const int bounded : {0, 2})
    EXPECT_NE(load_error(unchecked_file(TreeSetView(good.shape, {&extent, 1}, good.words), nullptr,
                                        0, kQtFormatVersion, bounded))
                  .find("bounds for " + std::to_string(bounded) + " of 1 channel groups"),
              std::string::npos)
        << bounded;
}

// Version 3 files (packed trees, bounds for group 0 only, no bounded_groups field) load as they
// are, in place, and convolve as they did.
TEST(QtFormat, Version3FilesLoadInPlace) {
  const PackedTree tree = sample_tree(32, 3, 2);
  const TreeExtent extent = whole_tree(tree);
  const QtFile file = QtFile::from_bytes(
      unchecked_file(TreeSetView(tree.shape, {&extent, 1}, tree.words), nullptr, 0, 3), "v3.qt");
  EXPECT_EQ(file.format_version(), 3u);
  EXPECT_TRUE(file.zero_copy());
  EXPECT_TRUE(same_words(file.tree().words(), tree.words));
  const PackedTree light = sample_tree(16, 1, 0);
  EXPECT_EQ(convolve(file.tree(), light.view()).value, convolve(tree.view(), light.view()).value);
}

// Version 5: trees with exact texels (captures) hold texel nodes of values alone. They write and
// load in place, convolve as the full nodes did within their bounds, and a first texel node that
// disagrees with the nodes' depths is refused by name. Capture sets of version 4 (full nodes,
// extents counted in nodes) still load and convolve as they did.
TEST(QtFormat, ExactTexelTreesLoadInPlaceAndOlderCaptureSetsStillLoad) {
  const Quadtree source = sample_float_tree(32, 3, 0, 0.0);  // random texels: every level
  const PackedTree full = pack(source), exact = pack_exact_texels(source);
  ASSERT_LT(exact.texel_start, std::size_t(exact.node_count()));
  ASSERT_LT(exact.words.size(), full.words.size());
  const QtFile file = QtFile::from_bytes(encode_tree(exact.view(), {}, {}), "exact.qt");
  EXPECT_EQ(file.format_version(), kQtFormatVersion);
  EXPECT_TRUE(file.tree().shape().exact_texels);
  EXPECT_EQ(file.tree().texel_start(), int(exact.texel_start));
  EXPECT_TRUE(same_words(file.tree().words(), exact.words));
  const PackedTree light = sample_tree(32, 3, 4);
  const Convolution with_full = convolve(light.view(), full.view());
  const Convolution with_exact = convolve(light.view(), file.tree());
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(with_exact.value[c], with_full.value[c], with_full.bound[c] + with_exact.bound[c]);
  // Texel nodes that start one node early, or late.
  for (const int shift : {-1, 1}) {
    TreeExtent extent = whole_tree(exact);
    extent.texel_start = std::uint32_t(int(extent.texel_start) + shift);
    const std::string error =
        load_error(unchecked_file(TreeSetView(exact.shape, {&extent, 1}, exact.words), nullptr));
    EXPECT_TRUE(error.find("texel nodes start at node") != std::string::npos ||
                error.find("node data hold") != std::string::npos)
        << error;
  }
  // A set without exact texels whose extent claims texel nodes.
  {
    TreeExtent extent = whole_tree(full);
    extent.texel_start -= 1;
    EXPECT_NE(load_error(unchecked_file(TreeSetView(full.shape, {&extent, 1}, full.words), nullptr))
                  .find("first texel node"),
              std::string::npos);
  }
  // A version 4 capture set, as earlier builds wrote them.
  const CaptureSet captures = sample_captures(5);
  const CaptureSetView view = captures.view();
  const QtFile v4 = QtFile::from_bytes(unchecked_file(view.trees, &view, 0, 4), "v4.qt");
  EXPECT_EQ(v4.format_version(), 4u);
  ASSERT_EQ(v4.captures().size(), 5u);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_TRUE(same_words(v4.captures().trees.tree(i).words(), captures.trees.tree(i).words()));
    EXPECT_EQ(convolve(light.view(), v4.captures().trees.tree(i)).value,
              convolve(light.view(), captures.trees.tree(i)).value);
  }
}

// Version 6: the texel nodes of RGB captures hold shared-exponent words. They write and load in
// place; a set of version 5 (texel nodes in halves) still loads and convolves as it did; an
// unknown encoding, or shared words in a tree that cannot hold them, is refused by name.
TEST(QtFormat, SharedExponentValuesLoadInPlaceAndVersion5TreesStillLoad) {
  const Quadtree source = sample_float_tree(32, 3, 0, 0.0);  // random texels: every level
  const PackedTree shared = pack_exact_texels(source);
  const PackedTree halves = pack_exact_texels(source, BoundKind::l2, ValueEncoding::halves);
  ASSERT_TRUE(shared.shape.shared_values());
  ASSERT_FALSE(halves.shape.shared_values());
  ASSERT_EQ(shared.texel_start, halves.texel_start);
  // Every node's values in 16 bytes instead of 24.
  EXPECT_EQ(halves.words.size() - shared.words.size(), std::size_t(shared.node_count()) * 2);
  const PackedTree light = sample_tree(32, 3, 4);
  // Version 6 (every node's values in place), as earlier builds wrote them.
  const TreeExtent v6_extent = whole_tree(shared);
  const QtFile file = QtFile::from_bytes(
      unchecked_file(TreeSetView(shared.shape, {&v6_extent, 1}, shared.words), nullptr, 0, 6),
      "shared.qt");
  EXPECT_EQ(file.format_version(), 6u);
  EXPECT_TRUE(file.zero_copy());
  EXPECT_TRUE(file.tree().shape().shared_values());
  EXPECT_TRUE(same_words(file.tree().words(), shared.words));
  EXPECT_EQ(convolve(light.view(), file.tree()).value, convolve(light.view(), shared.view()).value);
  // Version 5, as earlier builds wrote capture trees: halves, read as halves.
  const TreeExtent extent = whole_tree(halves);
  const QtFile v5 = QtFile::from_bytes(
      unchecked_file(TreeSetView(halves.shape, {&extent, 1}, halves.words), nullptr, 0, 5),
      "v5.qt");
  EXPECT_EQ(v5.format_version(), 5u);
  EXPECT_FALSE(v5.tree().shape().shared_values());
  const Convolution from_v5 = convolve(light.view(), v5.tree());
  EXPECT_EQ(from_v5.value, convolve(light.view(), halves.view()).value);
  const Convolution from_v6 = convolve(light.view(), file.tree());
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(from_v6.value[c], from_v5.value[c], from_v6.bound[c] + from_v5.bound[c]);
  // An unknown encoding; shared words claimed for a grey tree.
  const TreeExtent shared_extent = whole_tree(shared);
  EXPECT_NE(load_error(unchecked_file(TreeSetView(shared.shape, {&shared_extent, 1}, shared.words),
                                      nullptr, 0, kQtFormatVersion, 1, 7))
                .find("unknown value encoding 7"),
            std::string::npos);
  const PackedTree grey = pack_exact_texels(sample_float_tree(32, 1, 0, 0.0));
  const TreeExtent grey_extent = whole_tree(grey);
  EXPECT_NE(load_error(unchecked_file(TreeSetView(grey.shape, {&grey_extent, 1}, grey.words),
                                      nullptr, 0, kQtFormatVersion, 1, 1))
                .find("shared-exponent values need"),
            std::string::npos);
}

// Version 7: capture sets leave out the values and bounds of nodes refined over all four
// quadrants (a link word instead of 8), and loading restores them: the trees come back word for
// word, and so does re-encoding. Elided words that run out, the layout claimed for a set without
// derived values, an absurd node count, and a bound scale too small for the restored bounds are
// refused by name.
TEST(QtFormat, CaptureSetsLeaveOutRefinedValuesAndGetThemBack) {
  const CaptureSet captures = exact_captures(4);
  const CaptureSetView view = captures.view();
  int derived_nodes = 0;
  for (std::size_t i = 0; i < view.trees.size(); ++i)
    for (int n = 0; n < view.trees.tree(i).texel_start(); ++n)
      derived_nodes += (view.trees.tree(i).link(n) & 15u) == 15u;
  ASSERT_GT(derived_nodes, 100);
  const std::vector<std::byte> bytes = encode_capture_set(view, {}, test_provenance());
  const std::vector<std::byte> v6 = unchecked_file(view.trees, &view, 0, 6);
  // 7 words fewer per derived node.
  const auto* written = format::GetFile(bytes.data())->trees()->words();
  EXPECT_EQ(view.trees.words().size() - written->size(), 7u * std::size_t(derived_nodes));
  const QtFile file = QtFile::from_bytes(bytes, "captures.qt");
  EXPECT_EQ(file.format_version(), kQtFormatVersion);
  EXPECT_FALSE(file.zero_copy());
  // What the file stores, against what the trees take in memory once restored.
  EXPECT_EQ(file.stored_tree_bytes(),
            written->size() * sizeof(std::uint32_t) + view.size() * sizeof(TreeExtent));
  EXPECT_EQ(file.trees().bytes(), view.trees.bytes());
  ASSERT_EQ(file.captures().size(), view.size());
  const PackedTree light = sample_tree(32, 3, 4);
  for (std::size_t i = 0; i < view.size(); ++i) {
    EXPECT_EQ(file.captures().trees.tree(i).scales(), view.trees.tree(i).scales());
    EXPECT_TRUE(same_words(file.captures().trees.tree(i).words(), view.trees.tree(i).words()));
    EXPECT_EQ(convolve(light.view(), file.captures().trees.tree(i)).value,
              convolve(light.view(), view.trees.tree(i)).value);
    EXPECT_EQ(file.captures().trees.tree(i).derived_rounding(),
              view.trees.tree(i).derived_rounding());
  }
  EXPECT_EQ(encode_capture_set(file.captures(), {}, test_provenance()), bytes);
  // A version 6 set re-written: its refined nodes' values re-derived, within their bounds.
  const QtFile old = QtFile::from_bytes(v6, "v6.qt");
  EXPECT_TRUE(old.zero_copy());
  EXPECT_EQ(old.stored_tree_bytes(), old.trees().bytes());
  EXPECT_EQ(encode_capture_set(old.captures(), {}, test_provenance()), bytes);

  // Bad elided layouts, written without the writer's checks.
  const PackedTree tree = pack_exact_texels(sample_float_tree(32, 3, 0, 0.0));
  const std::vector<std::uint32_t> elided = elide_refined_values(tree.view());
  TreeExtent extent = whole_tree(tree);
  auto elided_file = [&](const PackedTree& t, const TreeExtent& e,
                         std::span<const std::uint32_t> words) {
    return unchecked_file(TreeSetView(t.shape, {&e, 1}, words), nullptr, 0, kQtFormatVersion, 1, -1,
                          true);
  };
  EXPECT_EQ(load_error(elided_file(tree, extent, elided)), "");
  EXPECT_NE(load_error(elided_file(tree, extent, {elided.data(), elided.size() - 1}))
                .find("need more words than the set holds"),
            std::string::npos);
  std::vector<std::uint32_t> longer = elided;
  longer.push_back(0);
  EXPECT_NE(load_error(elided_file(tree, extent, longer)).find("node data hold"),
            std::string::npos);
  const PackedTree halves =
      pack_exact_texels(sample_float_tree(32, 3, 0, 0.0), BoundKind::l2, ValueEncoding::halves);
  EXPECT_NE(load_error(elided_file(halves, whole_tree(halves), halves.words))
                .find("only sets of shared-exponent values"),
            std::string::npos);
  TreeExtent absurd = extent;
  absurd.node_count = 0x7fffffffu;
  EXPECT_NE(load_error(elided_file(tree, absurd, elided)).find("more than a tree of 32"),
            std::string::npos);
  TreeExtent small = extent;
  small.scales.bound_scale *= 0x1p-12f;
  EXPECT_NE(load_error(elided_file(tree, small, elided)).find("a derived bound exceeds"),
            std::string::npos);
}

// Values restored on loading are derived from their children's (refined_values.h). From a
// capture whose texels' roundings all go one way, the restored tree keeps the rounding its
// derived values need, and the loaded capture against a constant holds the texels' product
// within its bound.
TEST(QtFormat, RestoredValuesKeepTheirBoundWhenEveryRoundingGoesOneWay) {
  const int n = 16;
  const Grid grid = testing::one_way_rounding_grid(n);
  const PackedTree tree = pack_exact_texels(project(grid, {.tolerance = 0}));
  CaptureSet captures = exact_captures(1);
  captures.trees = TreeSet(tree.shape);
  captures.trees.append(tree.view());
  const QtFile file =
      QtFile::from_bytes(encode_capture_set(captures.view(), {}, test_provenance()), "one_way.qt");
  EXPECT_FALSE(file.zero_copy());
  const PackedTreeView loaded = file.captures().trees.tree(0);
  EXPECT_TRUE(same_words(loaded.words(), tree.words));
  EXPECT_EQ(loaded.derived_rounding(), tree.derived_rounding);
  EXPECT_GT(loaded.derived_rounding(), 1.0f);
  Grid grey(n, 1);
  for (float& t : grey.texels)
    t = 1;
  const PackedTree constant = pack(project(grey, {.tolerance = 0.05}));
  const Convolution r = convolve(constant.view(), loaded);
  for (int c = 0; c < 3; ++c) {
    double exact = 0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        exact += grid.at(0, c, x, y);
    exact /= n * n;
    EXPECT_LE(std::abs(double(r.value[c]) - exact), double(r.bound[c])) << c;
  }
}

// Loading checks and restores the trees of a set in parallel: many trees come back word for word
// whatever the number of threads, and of two trees refused, the first is named, as a reading
// in order names it (an extent out of place before it is named first); in-place sets alike.
TEST(QtFormat, TreesCheckedInParallelNameTheFirstRefused) {
  const PackedTree tree = pack_exact_texels(sample_float_tree(32, 3, 0, 0.0));
  const std::vector<std::uint32_t> elided = elide_refined_values(tree.view());
  constexpr std::uint32_t kTrees = 70;
  auto set_of = [&](std::span<const std::uint32_t> one, std::vector<TreeExtent>& extents,
                    std::vector<std::uint32_t>& words) {
    extents.clear();
    words.clear();
    for (std::uint32_t i = 0; i < kTrees; ++i) {
      TreeExtent e = whole_tree(tree);
      e.first_word = std::uint32_t(words.size());
      // Trees that differ, in their scales (by powers of two: the same words restored).
      e.scales.value_scale *= float(1u << (i % 8));
      e.scales.bound_scale *= float(1u << (i % 8));
      extents.push_back(e);
      words.insert(words.end(), one.begin(), one.end());
    }
  };
  std::vector<TreeExtent> extents;
  std::vector<std::uint32_t> words;
  set_of(elided, extents, words);
  // The points of a capture set of that many trees.
  const std::vector<Vec3> points(kTrees, Vec3::UnitZ()), tangents(kTrees, Vec3::UnitX());
  auto file_of = [&](std::span<const TreeExtent> e, std::span<const std::uint32_t> w, bool elide) {
    const TreeSetView trees(tree.shape, e, w);
    const CaptureSetView captures{points, points, tangents, trees, {}, {}};
    return unchecked_file(trees, &captures, 0, kQtFormatVersion, 1, -1, elide);
  };
  for (const int threads : {1, 2, 4}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                    std::size_t(threads));
    const QtFile file = QtFile::from_bytes(file_of(extents, words, true), "set.qt");
    ASSERT_EQ(file.trees().size(), kTrees);
    for (std::uint32_t i = 0; i < kTrees; ++i) {
      EXPECT_TRUE(same_words(file.trees().tree(i).words(), tree.words)) << i;
      EXPECT_EQ(file.trees().tree(i).scales(), extents[i].scales) << i;
    }
    // Tree 41's bounds do not fit its scale, tree 57 claims too many nodes: 41 is named.
    std::vector<TreeExtent> bad = extents;
    bad[41].scales.bound_scale *= 0x1p-12f;
    bad[57].node_count = 0x7fffffffu;
    EXPECT_NE(load_error(file_of(bad, words, true)).find("tree 41: a derived bound exceeds"),
              std::string::npos)
        << threads;
    bad[57] = extents[57];
    bad[60].node_count = 0x7fffffffu;
    bad[41] = extents[41];
    EXPECT_NE(load_error(file_of(bad, words, true)).find("tree 60: 2147483647 nodes"),
              std::string::npos);
    // Tree 12's extent is out of place: named before tree 60's problem.
    bad[12].first_word += 1;
    EXPECT_NE(load_error(file_of(bad, words, true)).find("tree extents are not contiguous"),
              std::string::npos);
    // Node data cut after tree 3 and three words of tree 4: the extents restore to over 8 times
    // the words the set holds, yet the first tree refused is named, not the set's size: tree 2,
    // whose bounds do not fit its scale; without it, tree 4, whose words run out.
    const std::vector<std::uint32_t> cut(words.begin(), words.begin() + extents[4].first_word + 3);
    ASSERT_GT(std::uint64_t(kTrees) * tree.words.size(), 8 * cut.size());
    bad = extents;
    bad[2].scales.bound_scale *= 0x1p-12f;
    EXPECT_NE(load_error(file_of(bad, cut, true)).find("tree 2: a derived bound exceeds"),
              std::string::npos)
        << threads;
    EXPECT_NE(load_error(file_of(extents, cut, true)).find("tree 4: "), std::string::npos)
        << threads;
    // In place (version 6 layout, every node whole): tree 33's broken link before tree 50's.
    std::vector<TreeExtent> whole_extents;
    std::vector<std::uint32_t> whole_words;
    set_of(tree.words, whole_extents, whole_words);
    EXPECT_EQ(load_error(file_of(whole_extents, whole_words, false)), "");
    const std::size_t node_words = std::size_t(tree.shape.words_per_node());
    whole_words[whole_extents[33].first_word] += 16;  // the root's children start elsewhere
    whole_words[whole_extents[50].first_word + node_words] += 16;
    EXPECT_NE(load_error(file_of(whole_extents, whole_words, false)).find("tree 33: node 0 links"),
              std::string::npos)
        << threads;
  }
}

TEST(QtFormat, WritesAreAtomic) {
  TempDir dir;
  const auto bytes = encode_tree(sample_tree(16, 1, 1).view(), {}, {});
  // Missing folder: an error naming the path, nothing created.
  EXPECT_THROW(write_qt(dir.file("no/such/folder/out.qt"), bytes), FileError);
  // A folder as output.
  fs::create_directories(dir.file("folder.qt"));
  EXPECT_THROW(write_qt(dir.file("folder.qt"), bytes), FileError);
  // A full device.
  if (fs::exists("/dev/full")) {
    EXPECT_THROW(write_qt("/dev/full", bytes), FileError);
  }
  // A failing writer leaves the old file untouched and no temporary behind.
  write_qt(dir.file("keep.qt"), bytes);
  EXPECT_THROW(write_file_atomically(dir.file("keep.qt"),
                                     [](const std::string& temp) {
                                       std::ofstream(temp) << "partial";
                                       throw FileError("writer failed");
                                     }),
               FileError);
  EXPECT_EQ(read_bytes(dir.file("keep.qt")), bytes);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"folder.qt", "keep.qt"}));
}

// Table entries are texel averages: entries marked as exact texels, which lookups cannot fold,
// are refused when written (and by the reader, with the same words).
TEST(QtFormat, TableEntriesOfExactTexelsAreRefused) {
  BrdfTable t;
  t.wo_resolution = 2;
  Grid g(8, 1, 1);
  for (float& v : g.texels)
    v = 0.25f;
  const PackedTree entry = pack_exact_texels(project(g, {.tolerance = 0}));
  ASSERT_TRUE(entry.shape.exact_texels);
  t.trees = TreeSet(entry.shape);
  for (int k = 0; k < 4; ++k)
    t.trees.append(entry.view());
  try {
    encode_brdf_table(t.view(), "lambert", "{}", {}, test_provenance());
    ADD_FAILURE() << "written";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("exact texels, which only captures hold"),
              std::string::npos)
        << e.what();
  }
}

// What capture2qt records reads back as the same recipe: light, scene, capture options, and
// the projection the trees were cut with.
TEST(QtRecipe, CaptureParametersReadBackAsTheSameRecipe) {
  CaptureRecipe constant;
  constant.constant = {0.1, 2.5e-7, 12345.678901234};
  constant.options = {.resolution = 32,
                      .strata = 3,
                      .seed = 987654321987654321ull,
                      .ray_offset = 3.25e-4,
                      .compact_lights = CaptureOptions::CompactLights::splatted};
  constant.projection = {.tolerance = 0.125, .mode = ProjectionOptions::Mode::absolute};
  CaptureRecipe map;
  map.environment = "maps/sunrise.exr";
  map.rotate_z_degrees = -37.5;
  map.scene = "scene.obj";
  map.options.compact_lights = CaptureOptions::CompactLights::apart;
  map.options.resolution = 32;  // the sample trees'
  for (const CaptureRecipe& r : {constant, map}) {
    const auto bytes = encode_capture_set(sample_captures(2).view(), r.projection,
                                          {"capture2qt", "1", capture_parameters(r), {}});
    const CaptureRecipe back = capture_recipe(QtFile::from_bytes(bytes, "c.qt"));
    EXPECT_EQ(back.environment, r.environment);
    EXPECT_EQ(back.constant, r.constant);  // bit for bit: the shortest text that reads back
    EXPECT_EQ(back.rotate_z_degrees, r.rotate_z_degrees);
    EXPECT_EQ(back.scene, r.scene);
    EXPECT_EQ(back.options.resolution, r.options.resolution);
    EXPECT_EQ(back.options.strata, r.options.strata);
    EXPECT_EQ(back.options.seed, r.options.seed);
    EXPECT_EQ(back.options.ray_offset, r.options.ray_offset);
    EXPECT_EQ(back.options.compact_lights, r.options.compact_lights);
    EXPECT_EQ(back.projection.tolerance, r.projection.tolerance);
    EXPECT_EQ(back.projection.mode, r.projection.mode);
  }
  // Files from elsewhere say nothing about their inputs.
  const auto foreign = encode_capture_set(sample_captures(2).view(), {}, test_provenance());
  EXPECT_THROW(capture_recipe(QtFile::from_bytes(foreign, "f.qt")), FileError);
}

// A recorded sample count no capture takes is refused by name: 2^31 - 1 used to send the
// strata's search (whose square overflowed) into a loop without end.
TEST(QtRecipe, SampleCountsNoCaptureTakesAreRefused) {
  CaptureRecipe r;
  r.environment = "sky.exr";
  r.options.resolution = 32;  // the sample trees'
  for (const long long spp : {2147483647LL, 4294967297LL, 4097LL, 0LL, -4LL}) {
    nlohmann::json parameters = nlohmann::json::parse(capture_parameters(r));
    parameters["spp"] = spp;
    const auto bytes = encode_capture_set(sample_captures(1).view(), r.projection,
                                          {"capture2qt", "1", parameters.dump(), {}});
    try {
      capture_recipe(QtFile::from_bytes(bytes, "odd.qt"));
      ADD_FAILURE() << spp << " samples per texel were taken";
    } catch (const FileError& e) {
      EXPECT_NE(std::string(e.what()).find("odd.qt: its provenance records " + std::to_string(spp) +
                                           " samples per texel"),
                std::string::npos)
          << e.what();
    }
  }
}

// A recorded resolution other than the trees' is refused by name (a reference traced at it
// failed later with a message about resolutions that did not name the file's provenance).
TEST(QtRecipe, ResolutionsOtherThanTheTreesAreRefused) {
  CaptureRecipe r;
  r.environment = "sky.exr";
  for (const int resolution : {16, 64, 32}) {
    r.options.resolution = resolution;
    const auto bytes = encode_capture_set(sample_captures(1).view(), r.projection,
                                          {"capture2qt", "1", capture_parameters(r), {}});
    const QtFile file = QtFile::from_bytes(bytes, "odd.qt");
    if (resolution == 32) {
      EXPECT_EQ(capture_recipe(file).options.resolution, 32);
      continue;
    }
    try {
      capture_recipe(file);
      ADD_FAILURE() << resolution << " was taken for the trees' 32";
    } catch (const FileError& e) {
      EXPECT_NE(std::string(e.what()).find("odd.qt: its provenance records captures of " +
                                           std::to_string(resolution) + "², its trees are 32²"),
                std::string::npos)
          << e.what();
    }
  }
}

// A capture run stops (std::length_error) once what its file would hold passes max_bytes:
// every point's position, frame and lights count as well as its tree, so that a run too large
// for one .qt file fails while it captures rather than when it writes. Checked against the
// size of the file its set encodes to: below that, less a few kilobytes of header, it stops.
TEST(QtFormat, CaptureRunsStopBeforeTheirFileOutgrowsItsLimit) {
  const Environment environment(testing::synthetic_sky());
  std::vector<SurfacePoint> points;
  for (int i = 0; i < 400; ++i)
    points.push_back({Vec3::Zero(), Vec3(std::sin(0.003 * i), 0, std::cos(0.003 * i))});
  CaptureSetOptions options;
  options.capture.resolution = 8;
  options.capture.compact_lights = CaptureOptions::CompactLights::apart;
  const CaptureSet set = capture_set(environment, nullptr, points, options);
  ASSERT_GT(set.lights.size(), 0u);
  const std::size_t file_bytes =
      encode_capture_set(set.view(), options.projection, test_provenance()).size();
  // The control: the trees alone (in memory, what was counted before) stay under the limit set
  // below, so that only the points' positions, frames and lights can reach it.
  ASSERT_LT(set.trees.view().bytes(), file_bytes - 4096);
  options.max_bytes = file_bytes - 4096;
  EXPECT_THROW(capture_set(environment, nullptr, points, options), std::length_error);
  options.max_bytes = 2 * file_bytes;
  EXPECT_NO_THROW(capture_set(environment, nullptr, points, options));
}

}  // namespace
}  // namespace basis
