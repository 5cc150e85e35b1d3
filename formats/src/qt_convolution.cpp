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

}  // namespace

// Every tree of a file as a full-resolution grid; with `lights`, each capture's directional
// lights splatted into its texels.
std::vector<Grid> dense_grids(const CaptureSetView& captures, bool lights) {
  std::vector<Grid> grids;
  for (std::size_t k = 0; k < captures.trees.size(); ++k) {
    grids.push_back(reconstruct(captures.trees.tree(k)));
    if (lights) splat_lights(captures.lights_of(k), grids.back());
  }
  return grids;
}

FileConvolution::FileConvolution(const QtFile& a, const QtFile& b, const ShadingOptions& shading,
                                 LightBrdf lights, Evaluation evaluation)
    : a_(a), b_(b), shading_(shading) {
  table_ = a.kind() == QtKind::brdf_table ? &a : b.kind() == QtKind::brdf_table ? &b : nullptr;
  other_ = table_ == &a ? &b : &a;
  if (table_ && other_->kind() == QtKind::brdf_table)
    throw FileError(b.name() + ": two BRDF tables cannot be convolved; give a table and captures");
  if (a.kind() == QtKind::capture_set && b.kind() == QtKind::capture_set) {
    const CaptureSetView ca = a.captures(), cb = b.captures();
    if (ca.size() != cb.size() ||
        !std::equal(ca.positions.begin(), ca.positions.end(), cb.positions.begin()) ||
        !std::equal(ca.normals.begin(), ca.normals.end(), cb.normals.begin()))
      throw FileError(b.name() + ": the two capture sets do not hold the same points");
  }
  size_ = table_ ? other_->trees().size() : std::max(a.trees().size(), b.trees().size());
  shading_.light_brdf = nullptr;
  if (table_ && other_->kind() == QtKind::capture_set && !other_->captures().lights.empty() &&
      lights == LightBrdf::spec) {
    try {
      light_spec_ = table_brdf(*table_);
      shading_.light_brdf = &light_spec_->brdf;
    } catch (const FileError& e) {
      warning_ = std::string(e.what()) + "; directional lights use the table's texels";
    }
  }
  if (evaluation == Evaluation::dense) {
    if (shading_.normal)
      throw std::invalid_argument("dense evaluation takes untilted lookups only (no --normal)");
    if (table_) {
      dense_table_ = dense_lookup(table_->brdf_table(), shading_.wo, shading_.interpolation);
      dense_b_ = dense_grids(as_captures(*other_), false);
    } else {
      dense_a_ = dense_grids(as_captures(a), true);
      dense_b_ = dense_grids(as_captures(b), true);
    }
  }
}

Convolution FileConvolution::operator()(std::size_t k) const {
  if (dense_table_) {
    const auto lights = other_->kind() == QtKind::capture_set ? other_->captures().lights_of(k)
                                                              : std::span<const DirectionalLight>();
    return shade_dense(*dense_table_, dense_b_[k], lights, shading_.light_brdf);
  }
  if (!dense_a_.empty()) {
    // A set of one capture stands for every point.
    const Grid& ga = dense_a_[dense_a_.size() == 1 ? 0 : k];
    const Grid& gb = dense_b_[dense_b_.size() == 1 ? 0 : k];
    Convolution result;
    const Rgb d = dense_convolve_simd(ga, gb);
    for (int c = 0; c < 3; ++c)
      result.value[c] = float(std::numbers::pi * d[c]);
    return result;
  }
  if (table_) {
    if (other_->kind() == QtKind::capture_set)
      return shade(table_->brdf_table(), other_->captures(), k, shading_);
    return reflect(table_->brdf_table(), other_->tree(), shading_.wo,
                   {shading_.convolution, shading_.interpolation});
  }
  return capture_product(as_captures(a_), as_captures(b_), k);
}

int FileConvolution::convolutions_per_result() const {
  if (!table_) return 1;
  if (shading_.normal) return shading_.tilt_mode == TiltCompensation::compensated ? 8 : 4;
  // Untilted: the entries around wo with a weight (lookups skip the others).
  int taps = 0;
  for (const TableTap& tap : lookup_taps(table_->brdf_table(), shading_.wo, shading_.interpolation))
    taps += tap.reads_anything();
  return taps;
}

}  // namespace basis
