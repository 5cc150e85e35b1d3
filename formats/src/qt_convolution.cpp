#include "basis/format/qt_convolution.h"

#include <algorithm>
#include <numbers>
#include <stdexcept>

#include "basis/core/dense.h"
#include "basis/lighting/capture.h"

#include "basis/brdf/table_lookup.h"
#include "basis/format/qt_recipe.h"

namespace basis {

namespace {

// A file as a capture set: a capture set itself, or its trees without points.
CaptureSetView as_captures(const QtFile& f) {
  return f.kind() == QtKind::capture_set ? f.captures()
                                         : CaptureSetView{{}, {}, {}, f.trees(), {}, {}};
}

// Every tree of a file as a full-resolution grid, at `resolution` when its own is coarser (the
// same function: a dense product needs grids of one resolution); with `lights`, each capture's
// directional lights splatted into its texels.
std::vector<Grid> dense_grids(const CaptureSetView& captures, bool lights, int resolution) {
  std::vector<Grid> grids;
  for (std::size_t k = 0; k < captures.trees.size(); ++k) {
    Grid grid = reconstruct(captures.trees.tree(k));
    if (lights) splat_lights(captures.lights_of(k), grid);
    grids.push_back(upsample(grid, std::max(resolution, grid.resolution)));
  }
  return grids;
}

// The finest resolution of a file's trees.
int finest_resolution(const CaptureSetView& captures) {
  int finest = 1;
  for (std::size_t k = 0; k < captures.trees.size(); ++k)
    finest = std::max(finest, captures.trees.tree(k).shape().resolution);
  return finest;
}

}  // namespace

FileConvolution::FileConvolution(const QtFile& a, const QtFile& b, const ShadingOptions& shading,
                                 LightBrdf lights, Evaluation evaluation, const FileRanges& ranges)
    : a_(a), shading_(shading) {
  table_ = a.kind() == QtKind::brdf_table ? &a : b.kind() == QtKind::brdf_table ? &b : nullptr;
  other_ = table_ == &a ? &b : &a;
  if (table_ && other_->kind() == QtKind::brdf_table)
    throw FileError(b.name() + ": two BRDF tables cannot be convolved; give a table and captures");
  auto within = [](const QtFile& f, const std::optional<PointRange>& range, PointRange& used) {
    const CaptureSetView all = as_captures(f);
    used = range.value_or(PointRange{0, all.trees.size()});
    if (f.kind() == QtKind::brdf_table) return all;
    if (used.end() > all.trees.size())
      throw std::invalid_argument(f.name() + ": captures " + std::to_string(used.first) + " .. " +
                                  std::to_string(used.end()) + " of a set of " +
                                  std::to_string(all.trees.size()));
    if (f.kind() != QtKind::capture_set) return all;
    return all.slice(used.first, used.count);
  };
  view_a_ = within(a, ranges.a, range_a_);
  view_b_ = within(b, ranges.b, range_b_);
  if (a.kind() == QtKind::capture_set && b.kind() == QtKind::capture_set) {
    const CaptureSetView& ca = view_a_;
    const CaptureSetView& cb = view_b_;
    if (ca.size() != cb.size() ||
        !std::equal(ca.positions.begin(), ca.positions.end(), cb.positions.begin()) ||
        !std::equal(ca.normals.begin(), ca.normals.end(), cb.normals.begin()))
      throw FileError(b.name() + ": the two capture sets do not hold the same points");
  }
  size_ = table_ ? shaded_captures().trees.size()
                 : std::max(view_a_.trees.size(), view_b_.trees.size());
  shading_.light_brdf = nullptr;
  if (table_ && other_->kind() == QtKind::capture_set && !shaded_captures().lights.empty() &&
      lights == LightBrdf::spec) {
    try {
      light_spec_ = table_brdf(*table_);
      shading_.light_brdf = &light_spec_->brdf;
    } catch (const FileError& e) {
      warning_ = std::string(e.what()) + "; directional lights use the table's texels";
    }
  }
  // An untilted lookup reads the same entries at every point: found and folded once (a wo that
  // lookups refuse is refused at the first lookup, as before). Dense products use their own
  // grid.
  const Vec3 wo = unit_direction(shading_.wo);
  if (table_ && !shading_.normal && wo != Vec3::Zero() && wo.z() >= 0 &&
      evaluation != Evaluation::dense)
    entries_ = entries_at(table_->brdf_table(), wo, shading_.interpolation,
                          /*with_texels=*/other_->kind() == QtKind::capture_set &&
                              !shading_.light_brdf && !shaded_captures().lights.empty());
  if (evaluation == Evaluation::dense) {
    if (shading_.normal)
      throw std::invalid_argument("dense evaluation takes untilted lookups only (no --normal)");
    if (table_) {
      dense_table_ = dense_lookup(table_->brdf_table(), shading_.wo, shading_.interpolation);
      const int resolution =
          std::max(dense_table_->grid.resolution, finest_resolution(shaded_captures()));
      dense_table_->grid = upsample(dense_table_->grid, resolution);
      dense_b_ = dense_grids(shaded_captures(), false, resolution);
    } else {
      const int resolution = std::max(finest_resolution(view_a_), finest_resolution(view_b_));
      dense_a_ = dense_grids(view_a_, true, resolution);
      dense_b_ = dense_grids(view_b_, true, resolution);
    }
  }
}

Convolution FileConvolution::operator()(std::size_t k) const {
  if (dense_table_) {
    const auto lights = other_->kind() == QtKind::capture_set ? shaded_captures().lights_of(k)
                                                              : std::span<const DirectionalLight>();
    Convolution result = shade_dense(*dense_table_, dense_b_[k], lights, shading_.light_brdf);
    // Values beyond the floats are refused, as the trees' descents refuse them.
    for (int c = 0; c < 3; ++c)
      result.value[c] = certified_float(result.value[c], 0).value;
    return result;
  }
  if (!dense_a_.empty()) {
    // A set of one capture stands for every point.
    const Grid& ga = dense_a_[dense_a_.size() == 1 ? 0 : k];
    const Grid& gb = dense_b_[dense_b_.size() == 1 ? 0 : k];
    Convolution result;
    const Rgb d = dense_convolve_simd(ga, gb);
    for (int c = 0; c < 3; ++c)
      result.value[c] = certified_float(std::numbers::pi * d[c], 0).value;
    return result;
  }
  if (table_) {
    if (other_->kind() == QtKind::capture_set)
      return entries_ ? shade(table_->brdf_table(), *entries_, shaded_captures(), k, shading_)
                      : shade(table_->brdf_table(), shaded_captures(), k, shading_);
    if (entries_)
      return reflect(table_->brdf_table(), *entries_, shaded_captures().trees.tree(k),
                     shading_.convolution);
    return reflect(table_->brdf_table(), shaded_captures().trees.tree(k), shading_.wo,
                   {shading_.convolution, shading_.interpolation});
  }
  return capture_product(view_a_, view_b_, k, shading_.convolution);
}

int FileConvolution::convolutions_per_result() const {
  if (!table_) return 1;
  if (shading_.normal) return shading_.tilt_mode == TiltCompensation::compensated ? 8 : 4;
  // Untilted: one dense product with the table's grid at wo, one descent of the folded entries,
  // or one per entry around wo with a weight (lookups skip the others).
  if (dense_table_ || (entries_ && entries_->folded)) return 1;
  int taps = 0;
  for (const TableTap& tap : lookup_taps(table_->brdf_table(), shading_.wo, shading_.interpolation))
    taps += tap.reads_anything();
  return taps;
}

std::uint64_t result_count(const CaptureSource& a, const CaptureSource& b) {
  if (a.kind() == QtKind::brdf_table) return b.size();
  if (b.kind() == QtKind::brdf_table) return a.size();
  if (a.kind() == QtKind::capture_set && b.kind() == QtKind::capture_set && a.size() > 1 &&
      b.size() > 1 && a.size() != b.size())
    throw FileError(b.path() + ": the two capture sets do not hold the same points (" +
                    std::to_string(a.size()) + " and " + std::to_string(b.size()) + ")");
  return std::max(a.size(), b.size());
}

void for_each_block(CaptureSource& a, CaptureSource& b, PointRange results, std::size_t max_block,
                    const std::function<void(const ConvolutionBlock& block)>& on_block) {
  const std::uint64_t total = result_count(a, b);
  if (results.end() > total)
    throw std::invalid_argument("results " + std::to_string(results.first) + " .. " +
                                std::to_string(results.end()) + " of " + std::to_string(total));
  // A capture set with a capture per result is walked point by point; a table, a single tree or
  // a set of one capture stands for every result.
  auto walked = [&](const CaptureSource& s) {
    return s.kind() == QtKind::capture_set && s.size() == total && (total > 1 || s.is_manifest());
  };
  const bool walk_a = walked(a), walk_b = walked(b);
  for (std::uint64_t p = results.first; p < results.end();) {
    std::uint64_t end =
        std::min<std::uint64_t>(results.end(), p + std::max<std::size_t>(1, max_block));
    std::size_t shard_a = 0, shard_b = 0;
    if (walk_a) {
      shard_a = a.shard_of(p);
      end = std::min(end, a.shard_points(shard_a).end());
    }
    if (walk_b) {
      shard_b = b.shard_of(p);
      end = std::min(end, b.shard_points(shard_b).end());
    }
    const QtFile& fa = a.shard(shard_a);
    const QtFile& fb = b.shard(shard_b);
    FileRanges ranges;
    if (walk_a) ranges.a = PointRange{p - a.shard_points(shard_a).first, end - p};
    if (walk_b) ranges.b = PointRange{p - b.shard_points(shard_b).first, end - p};
    on_block({p, end - p, fa, fb, ranges});
    p = end;
  }
}

}  // namespace basis
