// Full-resolution references for table lookups in capture sets, rebuilt from what the files
// record: the certified bound of every lookup is checked against them.
#pragma once

#include <memory>
#include <vector>

#include "basis/brdf/brdf.h"
#include "basis/brdf/brdf_table.h"
#include "basis/core/color.h"
#include "basis/core/task.h"
#include "basis/core/vector.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_recipe.h"
#include "basis/lighting/environment.h"
#include "basis/lighting/ray_scene.h"

namespace basis {

// The light and scene a capture recipe names, opened again (map read through OpenImageIO, OBJ
// traced with Embree). Throws FileError for inputs that moved or cannot be read, and for inputs
// whose checksum is not the one the recipe records (they changed since the capture).
struct CaptureInputs {
  Environment environment;
  std::unique_ptr<RayScene> scene;  // null when nothing occludes
};
CaptureInputs open_capture_inputs(const CaptureRecipe& recipe);

// Reflected radiance towards wo (local frame, untilted) at every capture of a capture set,
// without trees: the table's entries around wo re-tabulated at its resolution from the spec it
// stores (with their derivatives over wo when the table has them), each capture re-traced at
// full resolution from its recipe, the texel grids multiplied texel by texel and interpolated as
// the lookup interpolates (`interpolation`, as in table_lookup.h), plus f E cos for each light
// kept apart (f from `light_brdf` when given, else from the re-tabulated entries' texels).
// The value of a lookup differs from this by at most its certified bound. Throws FileError when
// the files do not say how they were made, std::invalid_argument for tables and captures of
// different resolutions. Captures run in parallel; progress is reported per capture and the
// work stops (Cancelled) when asked. Captures are re-traced with the jitter of their index in
// the whole run (a shard's first capture is not the run's first).
std::vector<Rgb> reference_lookups(const QtFile& table, const QtFile& captures, const Vec3& wo,
                                   const Brdf* light_brdf,
                                   WoInterpolation interpolation = WoInterpolation::hermite,
                                   const TaskControl& control = {});

// The same for captures [points.first, points.end()) of the file only.
std::vector<Rgb> reference_lookups(const QtFile& table, const QtFile& captures, PointRange points,
                                   const Vec3& wo, const Brdf* light_brdf,
                                   WoInterpolation interpolation = WoInterpolation::hermite,
                                   const TaskControl& control = {});

}  // namespace basis
