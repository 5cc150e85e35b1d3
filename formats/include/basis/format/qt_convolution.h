// Convolving two loaded .qt files: what the pair means, checked once, and its result at every
// point. A BRDF table with a capture set (either order) gives the reflected radiance at every
// capture, a table with a single tree the same for that tree, two trees or capture sets their
// integral point by point.
#pragma once

#include <functional>
#include <optional>

#include <string>
#include <vector>
#include "basis/core/shard.h"

#include "basis/brdf/brdf_spec.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_manifest.h"
#include "basis/lighting/shading.h"

namespace basis {

// Where f comes from for the directional lights of a capture set shaded by a table.
enum class LightBrdf {
  spec,   // the BRDF the table's stored spec describes, at the light's exact direction
  table,  // the table's entries, at the texel the light falls in
};

// How results are computed: by descending the trees, or with vectorised dense products of the
// trees' full-resolution reconstructions (built when the FileConvolution is made), which give
// the same values up to rounding and are what the trees' speed is measured against.
enum class Evaluation { trees, dense };

// Which captures of each file's capture set a FileConvolution covers: all when absent, else
// captures [first, first + count) of that file (a block of a large set, or a shard's part).
struct FileRanges {
  std::optional<PointRange> a, b;
};

class FileConvolution {
 public:
  // Checks the pair: two BRDF tables, or two capture sets of different points, are a FileError
  // naming b. With LightBrdf::spec and a capture set that holds lights, the table's spec is
  // parsed; if that fails (a measured BRDF's data file is missing) the table's entries are used
  // and warning() says why. Dense evaluation takes untilted lookups only (std::invalid_argument
  // otherwise). The files must outlive this object. With `ranges`, only the given captures of a
  // capture set count: result k is that of capture ranges.x->first + k, and two capture sets must
  // hold the same points over their ranges.
  FileConvolution(const QtFile& a, const QtFile& b, const ShadingOptions& shading,
                  LightBrdf lights = LightBrdf::spec, Evaluation evaluation = Evaluation::trees,
                  const FileRanges& ranges = {});
  FileConvolution(const FileConvolution&) = delete;
  FileConvolution& operator=(const FileConvolution&) = delete;

  // Number of results: one per capture (or tree) of the larger file, or of the one a table
  // shades.
  std::size_t size() const { return size_; }
  // Result k: the reflected radiance (pi included) with its certified bound, or the hemisphere
  // integral of A B cos of point k (bound 0 when evaluated densely).
  Convolution operator()(std::size_t k) const;

  // The BRDF table, when one of the files is a table; the file it shades.
  const QtFile* table() const { return table_; }
  const QtFile& shaded() const { return *other_; }
  // The captures the results are for, when the file a table shades is a capture set (within its
  // range), and that range within the file.
  const CaptureSetView& shaded_captures() const { return table_ == &a_ ? view_b_ : view_a_; }
  PointRange shaded_range() const { return table_ == &a_ ? range_b_ : range_a_; }
  // Each file as a capture set within its range (a tree or a table: its trees, without points).
  const CaptureSetView& captures_a() const { return view_a_; }
  const CaptureSetView& captures_b() const { return view_b_; }
  // Tree-by-tree convolutions each result costs: the table entries around wo with a weight
  // (at most 4) per untilted lookup, 4 or 8 (compensated) per tilted one, 1 for products.
  int convolutions_per_result() const;
  // The BRDF the lights are shaded with, when it comes from the table's spec.
  const Brdf* light_brdf() const { return shading_.light_brdf; }
  // Why the lights fall back to the table's entries; empty when they do not.
  const std::string& warning() const { return warning_; }

 private:
  const QtFile& a_;
  const QtFile* table_ = nullptr;
  const QtFile* other_ = nullptr;
  ShadingOptions shading_;
  // Each file as a capture set (a single tree: a set of one without points), within its range.
  CaptureSetView view_a_, view_b_;
  PointRange range_a_, range_b_;
  std::optional<BrdfSpec> light_spec_;
  std::string warning_;
  std::size_t size_ = 0;
  // The table entries an untilted lookup reads at every point, with their weights.
  std::optional<EntriesAtWo> entries_;
  // Dense evaluation: the table's entries around wo, and every tree of the other files as a
  // full-resolution grid, a capture's directional lights splatted into it for products.
  std::optional<DenseLookup> dense_table_;
  std::vector<Grid> dense_a_, dense_b_;
};

// The number of results two inputs give, as FileConvolution counts them: the captures (or
// trees) a table shades, else the larger input's (a set of one capture stands for every point).
// Throws FileError naming b when two capture sets hold different numbers of points.
std::uint64_t result_count(const CaptureSource& a, const CaptureSource& b);

// A block of results: results [first, first + count) are those of the files a and b over these
// ranges (a FileConvolution of them gives result first + k as its result k).
struct ConvolutionBlock {
  std::uint64_t first = 0;
  std::uint64_t count = 0;
  const QtFile& a;
  const QtFile& b;
  FileRanges ranges;
};

// Walks results [results.first, results.end()) of two inputs (.qt files or manifests) in blocks
// that lie within one shard of each manifest and hold at most max_block results, so that one
// shard of each input is open at a time and a block's dense grids or references stay bounded
// however large the sets. Shards are opened and checked as the walk reaches them
// (CaptureSource::shard). Calls on_block for each block in order.
void for_each_block(CaptureSource& a, CaptureSource& b, PointRange results, std::size_t max_block,
                    const std::function<void(const ConvolutionBlock& block)>& on_block);

}  // namespace basis
