// How a .qt file was made, read back from its provenance, so that its inputs can be rebuilt at
// full resolution: the BRDF a table tabulates and the capture parameters of a capture set.
#pragma once

#include <optional>
#include <string>

#include "basis/brdf/brdf_spec.h"
#include "basis/format/qt_file.h"
#include "basis/lighting/capture.h"

namespace basis {

// The BRDF of a table file, parsed from the spec it stores (data files such as MERL binaries
// are found relative to the spec's original folder). Throws FileError.
BrdfSpec table_brdf(const QtFile& table);

// What capture2qt recorded about a capture set: light, scene and capture options.
struct CaptureRecipe {
  std::string environment;  // map path, empty for a constant light
  Color constant{0, 0, 0};
  double rotate_z_degrees = 0;
  std::string scene;  // OBJ path, empty when nothing occludes
  CaptureOptions options;
};

// The recipe of a capture set made by capture2qt; throws FileError if the file does not say.
CaptureRecipe capture_recipe(const QtFile& captures);

}  // namespace basis
