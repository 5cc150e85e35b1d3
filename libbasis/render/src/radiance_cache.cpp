#include "basis/render/radiance_cache.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <nanoflann.hpp>
#include <numbers>
#include <stdexcept>

#include "basis/core/file_error.h"
#include "basis/core/projection.h"
#include "basis/lighting/ray_scene.h"
#include "basis/lighting/shading.h"

namespace basis {

std::uint64_t light_mask(const RenderScene& scene, const Vec3& position, const Vec3& normal,
                         const Vec3& geometric_normal) {
  const auto lights = scene.environment->lights();
  const std::size_t count = std::min<std::size_t>(64, lights.size());
  std::vector<Ray> rays;
  std::vector<std::size_t> which;
  const Vec3 origin = ray_origin_above(position, geometric_normal, scene.ray_offset);
  for (std::size_t l = 0; l < count; ++l)
    if (lights[l].direction.dot(normal) > 0 && lights[l].direction.dot(geometric_normal) > 0) {
      rays.push_back({origin, lights[l].direction});
      which.push_back(l);
    }
  std::vector<RayHit> hits(rays.size());
  if (!rays.empty()) scene.rays->trace(rays, hits);
  std::uint64_t mask = 0;
  for (std::size_t i = 0; i < rays.size(); ++i)
    if (!hits[i].hit) mask |= std::uint64_t(1) << which[i];
  return mask;
}

// The k-d tree over the records' positions.
struct RadianceCache::Index {
  struct Points {
    const std::vector<Vec3>* positions;
    std::size_t kdtree_get_point_count() const { return positions->size(); }
    double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*positions)[i][int(d)]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Points>,
                                                   Points, 3, std::uint32_t>;
  Points points;
  Tree tree;
  explicit Index(const std::vector<Vec3>& positions)
      : points{&positions}, tree(3, points, nanoflann::KDTreeSingleIndexAdaptorParams(8)) {
    tree.buildIndex();
  }
};

struct RadianceCache::Clock {
  std::atomic<long long> tracing{0}, projection{0}, lookup{0}, search{0};
};

namespace {

long long nanoseconds(double seconds) {
  return (long long)(seconds * 1e9);
}
double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

RadianceCache::RadianceCache(const RenderScene& scene, const CacheOptions& options)
    : scene_(&scene), options_(options), clock_(std::make_unique<Clock>()) {
  if (!is_valid_resolution(options.resolution))
    throw std::invalid_argument("record resolution must be a power of two from 2 to 512");
  if (options.strata < 1 || options.strata > 16)
    throw std::invalid_argument("record strata per axis must be 1..16");
  if (!(options.min_spacing > 0) || !(options.max_spacing >= options.min_spacing))
    throw std::invalid_argument("record spacing needs 0 < min <= max");
  if (!(options.radius_scale > 0)) throw std::invalid_argument("radius scale must be positive");
  if (!(options.max_normal_degrees > 0 && options.max_normal_degrees <= 90))
    throw std::invalid_argument("the largest normal difference must be 0 to 90 degrees");
  if (options.max_records < 1 || options.max_records > 16)
    throw std::invalid_argument("records per lookup must be 1..16");
  for (const Material& m : scene.materials) {
    if (!m.table) throw std::invalid_argument("the radiance cache needs the materials' tables");
    if (!options.dense) continue;
    const BrdfTableView t = m.table_view();
    if (t.trees.shape().resolution < options.resolution)
      throw std::invalid_argument("dense records of " + std::to_string(options.resolution) +
                                  " texels are finer than the table " + m.path);
    if (options.tilt == TiltCompensation::compensated && t.has_tilt() &&
        t.tilt.shape().resolution > options.resolution)
      throw std::invalid_argument("dense records are coarser than the tilt entries of " + m.path);
  }
  // Compensation reads every material's tilt entries, and dense records keep one copy of their
  // radiance at the tilt entries' resolution, which must then be the same for all materials.
  if (options.tilt == TiltCompensation::compensated)
    for (const Material& m : scene.materials) {
      const BrdfTableView t = m.table_view();
      if (!t.has_tilt())
        throw FileError(m.path +
                        ": the table holds no tilt derivatives, which the cache's "
                        "rotation compensation needs (tabulate it without --no-tilt, "
                        "or render with --tilt reparametrised)");
      if (options.dense &&
          t.tilt.shape().resolution != scene.materials.front().table_view().tilt.shape().resolution)
        throw std::invalid_argument("dense records need one tilt resolution for all materials");
    }
  if (options.dense)
    for (const Material& m : scene.materials)
      dense_tables_.push_back(std::make_unique<DenseTable>(m.table_view(), options.resolution));
  records_.light_offsets.push_back(0);
}

RadianceCache::~RadianceCache() = default;

void RadianceCache::add_records(std::span<const Site> sites, const TaskControl& control) {
  if (sites.empty()) return;
  CaptureOptions capture;
  capture.resolution = options_.resolution;
  capture.strata = options_.strata;
  capture.stratum_subsamples = options_.stratum_subsamples;
  capture.bright_subsamples = options_.bright_subsamples;
  capture.seed = options_.seed;
  capture.ray_offset = scene_->ray_offset;
  capture.compact_lights = CaptureOptions::CompactLights::apart;
  capture.occluder_distances = true;
  capture.shared_bright_rays = true;
  capture.prefiltered = true;
  ProjectionOptions projection;
  projection.tolerance = options_.tolerance;
  struct Made {
    PackedTree tree;
    Grid grid, tilt_grid;
    std::vector<DirectionalLight> lights;
    Frame frame;
    double radius = 0;
  };
  std::vector<Made> made(sites.size());
  const std::size_t first_index = size();
  std::atomic<bool> stop{false};
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, sites.size(), 1), [&](const auto& range) {
    QuadtreeProjector projector;
    Quadtree tree;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      if (stop || (control.cancel && control.cancel->load())) {
        stop = true;
        return;
      }
      const ShadingPoint& p = sites[i].point;
      Made& m = made[i];
      m.frame = Frame::from_normal(p.normal);
      const auto t0 = std::chrono::steady_clock::now();
      Capture c = capture_at(p, m.frame, capture, first_index + i);
      const auto t1 = std::chrono::steady_clock::now();
      clock_->tracing += nanoseconds(std::chrono::duration<double>(t1 - t0).count());
      const double spacing = p.footprint;
      m.radius = std::clamp(options_.radius_scale * c.occluder_distance(),
                            options_.min_spacing * spacing, options_.max_spacing * spacing);
      m.lights = std::move(c.lights);
      if (options_.dense) {
        m.grid = std::move(c.texels);
        if (options_.tilt == TiltCompensation::compensated && !dense_tables_.empty()) {
          const int r = dense_tables_[p.material]->tilt_resolution();
          if (r > 0) m.tilt_grid = downsample(m.grid, r);
        }
      } else {
        ProjectionOptions relative = projection;
        for (const DirectionalLight& light : m.lights)
          for (int ch = 0; ch < 3; ++ch)
            relative.extra_mean[ch] += light.energy[ch] * light.direction.z() / std::numbers::pi;
        projector.project(c.texels, relative, tree);
        m.tree = pack_exact_texels(tree, BoundKind::l2);
      }
      clock_->projection += nanoseconds(since(t1));
    }
  });
  if (stop) throw Cancelled();
  for (std::size_t i = 0; i < sites.size(); ++i) {
    Made& m = made[i];
    if (!options_.dense) {
      if (records_.trees.size() == 0) records_.trees = TreeSet(m.tree.shape);
      records_.trees.append(m.tree.view());
    } else {
      grids_.push_back(std::move(m.grid));
      tilt_grids_.push_back(std::move(m.tilt_grid));
    }
    records_.positions.push_back(sites[i].point.position);
    records_.normals.push_back(m.frame.normal);
    records_.tangents.push_back(m.frame.tangent);
    records_.lights.insert(records_.lights.end(), m.lights.begin(), m.lights.end());
    records_.light_offsets.push_back(std::uint32_t(records_.lights.size()));
    radius_.push_back(m.radius);
    lights_.push_back(sites[i].lights);
    max_radius_ = std::max(max_radius_, m.radius);
  }
  view_ = records_.view();
  index_ = std::make_unique<Index>(records_.positions);
}

Capture RadianceCache::capture_at(const ShadingPoint& p, const Frame& frame,
                                  const CaptureOptions& options, std::uint64_t index) const {
  return capture(*scene_->environment, scene_->rays.get(), p.position, frame, options, index);
}

int RadianceCache::find(const Site& site, std::span<Neighbour, 16> out) const {
  if (!index_) return 0;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::pair<std::uint32_t, double>> found;
  const double query[3] = {site.point.position.x(), site.point.position.y(),
                           site.point.position.z()};
  index_->tree.radiusSearch(query, max_radius_ * max_radius_, found,
                            nanoflann::SearchParams(0, 0, false));
  const double normal_scale =
      1 / std::sqrt(1 - std::cos(options_.max_normal_degrees * std::numbers::pi / 180));
  int count = 0;
  const int capacity = options_.max_records;
  for (const auto& [k, distance2] : found) {
    if (lights_[k] != site.lights) continue;
    const double r = radius_[k];
    const Vec3 offset = site.point.position - records_.positions[k];
    const double ep = std::sqrt(distance2) / r;
    const double ndot = std::clamp(site.point.normal.dot(records_.normals[k]), -1.0, 1.0);
    const double en = std::sqrt(std::max(0.0, 1 - ndot)) * normal_scale;
    const double weight = 1 - std::max(ep, en);
    if (!(weight > 0)) continue;
    // Ward: a record in front of the point sees what the point does not.
    if (offset.dot(site.point.normal + records_.normals[k]) / 2 < -0.05 * r) continue;
    // Keep the best `capacity`, ordered by weight (then index, for determinism).
    const Neighbour n{k, weight};
    auto better = [](const Neighbour& a, const Neighbour& b) {
      return a.weight > b.weight || (a.weight == b.weight && a.record < b.record);
    };
    if (count < capacity) {
      out[count++] = n;
    } else if (better(n, out[count - 1])) {
      out[count - 1] = n;
    } else {
      continue;
    }
    for (int i = count - 1; i > 0 && better(out[i], out[i - 1]); --i)
      std::swap(out[i], out[i - 1]);
  }
  add_search_time(since(t0));
  return count;
}

Rgb RadianceCache::radiance(std::uint32_t k, const ShadingPoint& point) const {
  const Material& material = scene_->materials[point.material];
  const Tilt tilt = capture_tilt(view_, k, point.normal);
  const Frame record = view_.frame(k);
  const Frame shading =
      options_.tilt == TiltCompensation::none ? record : tilted_frame(record, tilt);
  const Vec3 wo = above_horizon(shading.to_local(point.wo));
  if (!options_.dense) {
    ShadingOptions shade_options;
    shade_options.wo = wo;
    shade_options.normal = point.normal;
    shade_options.tilt_mode = options_.tilt;
    shade_options.light_brdf = &material.brdf;
    shade_options.convolution.accuracy = options_.lookup_accuracy;
    return shade(material.table_view(), view_, k, shade_options).value;
  }
  Convolution c = reflect_tilted_dense(*dense_tables_[point.material], grids_[k], tilt_grids_[k],
                                       wo, tilt, options_.tilt);
  const Rgb lights = reflect_lights(view_.lights_of(k), record, shading, wo, material.brdf);
  for (int ch = 0; ch < 3; ++ch)
    c.value[ch] += lights[ch];
  return c.value;
}

Rgb RadianceCache::interpolate(std::span<const Neighbour> neighbours,
                               const ShadingPoint& point) const {
  const auto t0 = std::chrono::steady_clock::now();
  double sum[3] = {0, 0, 0}, total = 0;
  for (const Neighbour& n : neighbours) {
    const Rgb l = radiance(n.record, point);
    for (int c = 0; c < 3; ++c)
      sum[c] += n.weight * l[c];
    total += n.weight;
  }
  add_lookup_time(since(t0));
  Rgb out{};
  if (total > 0)
    for (int c = 0; c < 3; ++c)
      out[c] = float(sum[c] / total);
  return out;
}

std::size_t RadianceCache::bytes() const {
  if (!options_.dense) return records_.trees.view().bytes();
  std::size_t b = 0;
  for (const Grid& g : grids_)
    b += g.texels.size() * sizeof(float);
  for (const Grid& g : tilt_grids_)
    b += g.texels.size() * sizeof(float);
  return b;
}

CacheTimings RadianceCache::timings() const {
  return {clock_->tracing * 1e-9, clock_->projection * 1e-9, clock_->lookup * 1e-9,
          clock_->search * 1e-9};
}

void RadianceCache::add_lookup_time(double seconds) const {
  clock_->lookup += nanoseconds(seconds);
}
void RadianceCache::add_search_time(double seconds) const {
  clock_->search += nanoseconds(seconds);
}

}  // namespace basis
