// How a .qt file was made, written into its provenance and read back from it, so that its
// inputs can be rebuilt at full resolution: the BRDF a table tabulates and the light, scene and
// parameters of a capture set.
#pragma once

#include <optional>
#include <string>

#include "basis/brdf/brdf_spec.h"
#include "basis/brdf/brdf_table.h"
#include "basis/core/shard.h"
#include "basis/format/qt_file.h"
#include "basis/lighting/capture.h"

namespace basis {

// The BRDF of a table file, parsed from the spec it stores (data files such as MERL binaries
// are found relative to the spec's original folder). Throws FileError, also when the data file
// is not the one the table was made from (its checksum, recorded in the provenance's parameters
// as data_checksum, differs).
BrdfSpec table_brdf(const QtFile& table);

// The options brdf2qt tabulates a spec with by default: BrdfTableOptions' defaults, the outgoing
// resolution the BRDF needs (default_wo_resolution), and the spec's "table" block over them.
BrdfTableOptions table_options(const BrdfSpec& spec);

// The options a table was tabulated with, as the parameters (JSON text) of its provenance:
// wo_res, wi_res, tolerance, tolerance_floor, wo_derivatives, mode, tilt_derivatives, bounds,
// and for a measured BRDF the checksum of its data file (brdf_data_checksum) as data_checksum.
std::string table_parameters(const BrdfTableOptions& options, const Brdf& brdf);

// Which part of a sharded run a capture set holds (capture2qt --shard): shard `shard` of a run
// of `total_points` points, whose captures are the run's points shard_range(total_points, shard).
struct CaptureShard {
  Shard shard;
  std::uint64_t total_points = 0;

  PointRange points() const { return shard_range(total_points, shard); }
  bool operator==(const CaptureShard&) const = default;
};

// What a capture set was made from: light, scene, capture and projection options, and for a
// shard of a sharded run, which one.
struct CaptureRecipe {
  std::string environment;  // map path, empty for a constant light
  Color constant{0, 0, 0};
  double rotate_z_degrees = 0;
  std::string scene;  // OBJ path, empty when nothing occludes
  // What the map and scene held when captured (capture_inputs_checksum), empty for sets made
  // before it was recorded.
  std::string inputs_checksum;
  CaptureOptions options;
  ProjectionOptions projection;
  std::optional<CaptureShard> shard;

  // The run's index of the set's first capture (its jitter counts from it): 0 unless a shard.
  std::uint64_t first_index() const { return shard ? shard->points().first : 0; }
};

// The recipe as the parameters (JSON text) of a capture set's provenance, which
// capture_recipe reads back; the inputs' checksum as "inputs_xxh128" when there is one, so
// that shards whose map or scene changed between them are not of one run. A shard's are the
// whole run's with "shard": {"index", "count", "total_points"} as the last field. Throws FileError
// naming a map or scene whose name is not UTF-8 (JSON could not record it as itself).
std::string capture_parameters(const CaptureRecipe& recipe);

// The parameters of the whole run that a shard's parameters (JSON text) belong to: the same text
// without its "shard" field, exactly as capture_parameters writes it for one process. Throws
// FileError naming `name` for text that is not a JSON object.
std::string run_parameters(const std::string& parameters, const std::string& name);

// The recipe of a capture set made by capture2qt (or the Python module's capture()); throws
// FileError if the file does not say.
// The projection options are those its trees were cut with.
CaptureRecipe capture_recipe(const QtFile& captures);

}  // namespace basis
