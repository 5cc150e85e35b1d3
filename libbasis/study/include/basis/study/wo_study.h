// Lookups between BRDF table entries under high-contrast light: the error against the outgoing
// direction's offset from the nearest entry, for the first version's tables (33^2 entries,
// bilinear) and the default ones (derivatives over wo, Hermite), and where the error comes from.
#pragma once

#include <string>
#include <vector>

#include "basis/brdf/brdf.h"
#include "basis/core/file_error.h"
#include "basis/core/task.h"
#include "basis/core/vector.h"
#include "basis/io/image.h"
#include "basis/lighting/environment.h"

namespace basis {

// A lat-long map of sharp bright windows (radiance 30 to 200, a few pixels to a few dozen wide)
// on a dark ground (0.02), 256 x 128: contrast in the sky itself, no compact sun.
Image bright_windows_map();

struct WoStudyMap {
  std::string name;
  Environment environment;
};

// The windows map, then one map per file (named by its stem, read through OpenImageIO).
std::vector<WoStudyMap> wo_study_maps(const std::vector<std::string>& files);

struct WoStudyBrdf {
  std::string name;
  Brdf brdf;
};

// `count` directions up to `max_degrees` from the normal whose parabolic coordinates lie in the
// middle of a cell of an m x m table's grid (fractions 0.2 to 0.8 along s and t): as far from
// the entries as directions get. The same on every build (seeded, draws in order).
std::vector<Vec3> directions_between_entries(int m, int count, double max_degrees = 70);

// Lambert 0.2 + Phong 100 and 200 (ks 0.6, 0.8), GGX 0.1 (kd 0.1, f0 0.9); quick: the first.
std::vector<WoStudyBrdf> wo_study_brdfs(bool quick);

// One point of the chart: lookups in `method`'s table at directions `offset` grid steps from
// an entry along both s and t (0 at the entry, 0.5 at the middle of a cell), from several cells
// up to 60 degrees, against direct integration over the map's pixels; relative errors over the
// cells and channels. Methods: "bilinear" (33^2 entries without derivatives, cut relative to
// the mean: the first version's tables) and "hermite" (the default tables).
struct WoStudyRow {
  std::string brdf, map, method;
  int wo_resolution = 0;
  double offset = 0;
  double mean_error = 0, max_error = 0;
};
std::vector<WoStudyRow> wo_offset_study(const std::vector<WoStudyMap>& maps,
                                        const std::vector<WoStudyBrdf>& brdfs, bool quick,
                                        const TaskControl& control = {});

// Where the error of a lookup between entries comes from, each the largest relative error over
// the maps, 24 directions between entries up to 70 degrees and the channels, at the capture's
// zenith (128^2, compact lights apart):
//   texels: the full-resolution product of f tabulated at wo with the capture's texels, against
//           direct integration over the map's pixels;
//   table tree, capture tree: that product with one factor compressed as the defaults compress
//           it;
//   interpolation: the default table's Hermite lookup against both trees at wo;
//   total, bilinear total: the lookups against direct integration.
struct WoErrorSources {
  std::string brdf;
  int wo_resolution = 0;
  double texels = 0, table_tree = 0, capture_tree = 0, interpolation = 0, total = 0,
         bilinear_total = 0;
};
std::vector<WoErrorSources> wo_error_sources(const std::vector<WoStudyMap>& maps,
                                             const std::vector<WoStudyBrdf>& brdfs,
                                             const TaskControl& control = {});

// CSV files: brdf,map,method,wo_resolution,offset,mean_error,max_error and
// brdf,wo_resolution,texels,table_tree,capture_tree,interpolation,total,bilinear_total. Throw
// FileError when they cannot be written.
void write_wo_csv(const std::string& path, const std::vector<WoStudyRow>& rows);
void write_wo_sources_csv(const std::string& path, const std::vector<WoErrorSources>& rows);

}  // namespace basis
