#include "basis/format/qt_convolution.h"

#include <algorithm>

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

FileConvolution::FileConvolution(const QtFile& a, const QtFile& b, const ShadingOptions& shading,
                                 LightBrdf lights)
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
}

Convolution FileConvolution::operator()(std::size_t k) const {
  if (table_) {
    if (other_->kind() == QtKind::capture_set)
      return shade(table_->brdf_table(), other_->captures(), k, shading_);
    return reflect(table_->brdf_table(), other_->tree(), shading_.wo);
  }
  return capture_product(as_captures(a_), as_captures(b_), k);
}

int FileConvolution::convolutions_per_result() const {
  if (!table_) return 1;
  return shading_.normal && shading_.tilt_mode == TiltCompensation::compensated ? 8 : 4;
}

}  // namespace basis
