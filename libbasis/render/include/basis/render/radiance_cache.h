// A radiance cache in Krivanek's manner over hemisphere captures: records of incident radiance
// at surface points, each valid within a radius from the harmonic mean distance of its
// occluders, found through a k-d tree (nanoflann), interpolated with Ward's and Tabellion's
// weights, and shaded through the tilted table lookup (rotation compensation).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "basis/brdf/table_lookup.h"
#include "basis/lighting/capture.h"
#include "basis/render/dense_table.h"
#include "basis/render/render_scene.h"
#include "basis/render/shading_point.h"

namespace basis {

struct CacheOptions {
  int resolution = 32;         // record texels per side
  int strata = 1;              // rays per texel: strata^2
  int stratum_subsamples = 1;  // environment samples per axis averaging a stratum (at most)
  int bright_subsamples = 1;   // pieces per axis of each bright environment pixel
  double tolerance = 0.05;     // projection of the records into trees, relative to their mean
  // A record's validity radius: radius_scale x the harmonic mean distance of its occluders,
  // clamped to [min_spacing, max_spacing] pixels' worth of world length at the record.
  double radius_scale = 1;
  double min_spacing = 1.5;
  double max_spacing = 6;
  double max_normal_degrees = 15;  // normals further apart than this do not share records
  int max_records = 4;             // K, records interpolated per point (1..16)
  // Accuracy target of the quadtree records' lookups (ConvolutionOptions::accuracy); 0
  // descends to the leaves. Dense records are exact products whatever it says.
  double lookup_accuracy = 0;
  // Records are stored as trees (the quadtree cache) or dense grids (the regular-texture cache)
  // at the same resolution, shaded with the same lookups.
  bool dense = false;
  TiltCompensation tilt = TiltCompensation::compensated;
  std::uint64_t seed = 1;
};

// Which of the environment's compact lights (the 64 most luminous, Environment::lights' order;
// dimmer ones beyond them are not told apart) a point sees: bit l is set when
// light l's centre is above the horizon of `normal` and its shadow ray escapes. Records are
// used only where the point sees the same lights, so that no record carries a sun across a
// shadow's edge.
std::uint64_t light_mask(const RenderScene& scene, const Vec3& position, const Vec3& normal,
                         const Vec3& geometric_normal);

// Time spent in the cache's phases, summed over threads.
struct CacheTimings {
  double tracing = 0, projection = 0, lookup = 0, search = 0;
};

class RadianceCache {
 public:
  // Throws std::invalid_argument for options out of range, or dense records finer than a
  // material's table or coarser than its tilt entries.
  RadianceCache(const RenderScene& scene, const CacheOptions& options);
  ~RadianceCache();

  // A point that may need a record: where, and its pixel's footprint (ShadingPoint).
  struct Site {
    ShadingPoint point;
    std::uint64_t lights = 0;  // light_mask
  };

  // Captures a record at every site (in parallel, appended in order, so deterministic) and
  // rebuilds the k-d tree. Throws Cancelled when the control asks.
  void add_records(std::span<const Site> sites, const TaskControl& control = {});

  struct Neighbour {
    std::uint32_t record = 0;
    double weight = 0;
  };
  // The valid records at a site, up to max_records of the highest weights, best first; returns
  // how many. Tabellion's weight 1 - max(d / R, sqrt(1 - n . n_i) / sqrt(1 - cos a_max)) must
  // be positive, the record must not lie in front of the point (Ward), and it must see the
  // site's lights.
  int find(const Site& site, std::span<Neighbour, 16> out) const;

  // Reflected radiance towards the eye at the point from record k, tilted to the point's normal.
  Rgb radiance(std::uint32_t k, const ShadingPoint& point) const;
  // Weighted mean of the neighbours' radiance (CacheTimings::lookup counts their lookups).
  Rgb interpolate(std::span<const Neighbour> neighbours, const ShadingPoint& point) const;

  std::size_t size() const { return radius_.size(); }
  std::size_t bytes() const;  // of the records' trees or grids
  CacheTimings timings() const;
  void add_lookup_time(double seconds) const;
  void add_search_time(double seconds) const;

 private:
  struct Index;
  Capture capture_at(const ShadingPoint& point, const Frame& frame, const CaptureOptions& options,
                     std::uint64_t index) const;
  const RenderScene* scene_;
  CacheOptions options_;
  CaptureSet records_;  // positions, frames, lights (and trees unless dense)
  CaptureSetView view_;
  std::vector<double> radius_;
  std::vector<std::uint64_t> lights_;
  std::vector<Grid> grids_, tilt_grids_;                   // dense records
  std::vector<std::unique_ptr<DenseTable>> dense_tables_;  // per material, dense records
  std::unique_ptr<Index> index_;
  double max_radius_ = 0;
  struct Clock;
  std::unique_ptr<Clock> clock_;
};

}  // namespace basis
