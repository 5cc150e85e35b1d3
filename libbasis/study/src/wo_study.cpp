#include "basis/study/wo_study.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <span>
#include <sstream>

#include "basis/brdf/brdf_table.h"
#include "basis/core/dense.h"
#include "basis/core/parabolic.h"
#include "basis/io/atomic_file.h"
#include "basis/io/image_file.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/shading.h"
#include "basis/study/reference.h"

namespace basis {

Image bright_windows_map() {
  const int w = 256, h = 128;
  Image image(w, h, 3);
  for (float& p : image.pixels)
    p = 0.02f;
  struct Window {
    int column, row, columns, rows;
    float radiance;
  };
  const Window windows[] = {{20, 20, 6, 10, 60},   {60, 35, 4, 4, 200}, {100, 10, 10, 6, 40},
                            {150, 45, 3, 12, 100}, {200, 25, 8, 8, 80}, {230, 55, 5, 3, 150},
                            {128, 2, 40, 3, 30}};
  for (const Window& win : windows)
    for (int y = win.row; y < win.row + win.rows; ++y)
      for (int x = win.column; x < win.column + win.columns; ++x)
        for (int c = 0; c < 3; ++c)
          image.at(x % w, y, c) = win.radiance * (1 - 0.1f * c);
  return image;
}

std::vector<Vec3> directions_between_entries(int m, int count, double max_degrees) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> unit(-1, 1);
  const double r_max = std::tan(max_degrees * std::numbers::pi / 180 / 2);
  std::vector<Vec3> out;
  while (int(out.size()) < count) {
    const double s = unit(rng) * r_max, t = unit(rng) * r_max;  // in this order on every build
    if (std::hypot(s, t) > r_max) continue;
    bool middle = true;
    for (const double x : {s, t}) {
      const double g = (x + 1) / 2 * (m - 1), f = g - std::floor(g);
      middle = middle && f >= 0.2 && f <= 0.8;
    }
    if (middle) out.push_back(parabolic_to_hemisphere(Vec2(s, t)));
  }
  return out;
}

std::vector<WoStudyMap> wo_study_maps(const std::vector<std::string>& files) {
  std::vector<WoStudyMap> maps;
  maps.push_back({"windows", Environment(bright_windows_map(), 0, "windows")});
  for (const std::string& file : files) {
    const std::string name = std::filesystem::path(file).stem().string();
    maps.push_back({name, Environment(read_image(file), 0, file)});
  }
  return maps;
}

std::vector<WoStudyBrdf> wo_study_brdfs(bool quick) {
  std::vector<WoStudyBrdf> all = {{"phong100", Phong{{0.2, 0.2, 0.2}, {0.6, 0.6, 0.6}, 100}},
                                  {"ggx0.1", Ggx{{0.1, 0.1, 0.1}, {0.9, 0.9, 0.9}, 0.1}},
                                  {"phong200", Phong{{0.1, 0.1, 0.1}, {0.8, 0.8, 0.8}, 200}}};
  if (quick) all.resize(1);
  return all;
}

namespace {

const Frame kZenith = Frame::from_normal(Vec3::UnitZ());

// The first version's tables (33^2 entries, no derivatives, cut relative to the mean) or the
// default ones, for lookups at `directions` only (a partial table).
BrdfTable study_table(const Brdf& brdf, bool first_version, const std::vector<Vec3>& directions) {
  BrdfTableOptions options;
  options.tilt_derivatives = false;
  options.only_for = directions;
  if (first_version) {
    options.wo_resolution = 33;
    options.wo_derivatives = false;
    options.projection.local_floor = 0;
  } else {
    options.wo_resolution = default_wo_resolution(brdf);
  }
  return tabulate_brdf(brdf, options);
}

// The capture at the zenith as capture2qt makes it (128^2, compact lights apart), and its texels
// before projection when asked.
CaptureSet zenith_capture(const Environment& environment, Grid* texels = nullptr) {
  const SurfacePoint zenith{Vec3::Zero(), Vec3::UnitZ()};
  CaptureSetOptions options;
  options.capture.compact_lights = CaptureOptions::CompactLights::apart;
  if (texels)
    options.on_grid = [texels](std::size_t, const Grid& grid, std::span<const DirectionalLight>) {
      *texels = grid;
    };
  return capture_set(environment, nullptr, {&zenith, 1}, options);
}

// Direct integration over the map's pixels at every direction, in parallel.
std::vector<Color> exact_reflections(const Environment& environment, const Brdf& brdf,
                                     const std::vector<Vec3>& directions) {
  std::vector<Color> out(directions.size());
  tbb::parallel_for(std::size_t(0), directions.size(), [&](std::size_t k) {
    out[k] =
        reference_reflection(environment, nullptr, Vec3::Zero(), kZenith, brdf, directions[k], 3);
  });
  return out;
}

double relative(double value, double exact) {
  return std::abs(value - exact) / std::abs(exact);
}

}  // namespace

std::vector<WoStudyRow> wo_offset_study(const std::vector<WoStudyMap>& maps,
                                        const std::vector<WoStudyBrdf>& brdfs, bool quick,
                                        const TaskControl& control) {
  std::vector<double> offsets;
  for (int k = 0; k <= 10; k += quick ? 5 : 1)
    offsets.push_back(0.05 * k);
  const int cells = quick ? 3 : 8;
  std::vector<WoStudyRow> rows;
  std::size_t done = 0;
  const std::size_t total = brdfs.size() * 2;
  for (const WoStudyBrdf& b : brdfs)
    for (const bool first_version : {true, false}) {
      control.check();
      const int m = first_version ? 33 : default_wo_resolution(b.brdf);
      const double h = 2.0 / (m - 1), r_max = std::tan(30 * std::numbers::pi / 180);
      // Cells whose middle lies within 60 degrees of the normal, the same for every method.
      std::mt19937 rng(5);
      std::uniform_real_distribution<double> unit(-r_max, r_max);
      std::vector<Vec3> directions;
      for (int c = 0; c < cells;) {
        const double x = unit(rng), y = unit(rng);
        const Vec2 middle(x, y);
        if (middle.norm() > r_max) continue;
        const double i0 = std::floor((middle.x() + 1) / h), j0 = std::floor((middle.y() + 1) / h);
        for (const double f : offsets)
          directions.push_back(parabolic_to_hemisphere(Vec2(-1 + h * (i0 + f), -1 + h * (j0 + f))));
        ++c;
      }
      const BrdfTable table = study_table(b.brdf, first_version, directions);
      for (const WoStudyMap& map : maps) {
        const CaptureSet set = zenith_capture(map.environment);
        const std::vector<Color> exact = exact_reflections(map.environment, b.brdf, directions);
        for (std::size_t o = 0; o < offsets.size(); ++o) {
          WoStudyRow row{b.name, map.name, first_version ? "bilinear" : "hermite", m, offsets[o],
                         0,      0};
          for (int c = 0; c < cells; ++c) {
            const std::size_t k = std::size_t(c) * offsets.size() + o;
            ShadingOptions shading;
            shading.wo = directions[k];
            shading.light_brdf = &b.brdf;
            shading.interpolation =
                first_version ? WoInterpolation::bilinear : WoInterpolation::hermite;
            const Convolution r = shade(table.view(), set.view(), 0, shading);
            for (int ch = 0; ch < 3; ++ch) {
              const double e = relative(r.value[ch], exact[k][ch]);
              row.mean_error += e / (3.0 * cells);
              row.max_error = std::max(row.max_error, e);
            }
          }
          rows.push_back(row);
        }
      }
      control.report(++done, total);
    }
  return rows;
}

std::vector<WoErrorSources> wo_error_sources(const std::vector<WoStudyMap>& maps,
                                             const std::vector<WoStudyBrdf>& brdfs,
                                             const TaskControl& control) {
  std::vector<WoErrorSources> out;
  for (const WoStudyBrdf& b : brdfs) {
    control.check();
    const int m = default_wo_resolution(b.brdf);
    const std::vector<Vec3> directions = directions_between_entries(m, 24);
    const BrdfTable table = study_table(b.brdf, false, directions);
    BrdfTableOptions defaults;
    std::vector<Grid> at_wo(directions.size());
    std::vector<PackedTree> compressed(directions.size()), exact_entry(directions.size());
    tbb::parallel_for(std::size_t(0), directions.size(), [&](std::size_t k) {
      at_wo[k] = tabulate_entry(b.brdf, directions[k], defaults);
      compressed[k] = pack(project(at_wo[k], defaults.projection));
      exact_entry[k] = pack(project(at_wo[k], {.tolerance = 0}));
    });
    WoErrorSources s{b.name, m};
    for (const WoStudyMap& map : maps) {
      Grid texels;
      const CaptureSet set = zenith_capture(map.environment, &texels);
      const CaptureSetView view = set.view();
      const PackedTree capture_exact = pack(project(texels, {.tolerance = 0}));
      const std::vector<Color> exact = exact_reflections(map.environment, b.brdf, directions);
      for (std::size_t k = 0; k < directions.size(); ++k) {
        Color lights{0, 0, 0};
        for (const DirectionalLight& l : view.lights_of(0)) {
          const Color f = evaluate(b.brdf, l.direction, directions[k]);
          for (int ch = 0; ch < 3; ++ch)
            lights[ch] += f[ch] * l.energy[ch] * l.direction.z();
        }
        const Rgb dense = dense_convolve_naive(at_wo[k], texels);
        const Convolution table_tree = convolve(compressed[k].view(), capture_exact.view());
        const Convolution capture_tree = convolve(exact_entry[k].view(), view.trees.tree(0));
        const Convolution both = convolve(compressed[k].view(), view.trees.tree(0));
        ShadingOptions shading;
        shading.wo = directions[k];
        shading.light_brdf = &b.brdf;
        const Convolution hermite = shade(table.view(), view, 0, shading);
        shading.interpolation = WoInterpolation::bilinear;
        const Convolution bilinear = shade(table.view(), view, 0, shading);
        const double pi = std::numbers::pi;
        for (int ch = 0; ch < 3; ++ch) {
          const double product = pi * dense[ch] + lights[ch], x = exact[k][ch];
          s.texels = std::max(s.texels, relative(product, x));
          s.table_tree =
              std::max(s.table_tree, std::abs(pi * (table_tree.value[ch] - dense[ch])) / x);
          s.capture_tree =
              std::max(s.capture_tree, std::abs(pi * (capture_tree.value[ch] - dense[ch])) / x);
          s.interpolation = std::max(
              s.interpolation, std::abs(hermite.value[ch] - pi * both.value[ch] - lights[ch]) / x);
          s.total = std::max(s.total, relative(hermite.value[ch], x));
          s.bilinear_total = std::max(s.bilinear_total, relative(bilinear.value[ch], x));
        }
      }
    }
    out.push_back(s);
  }
  return out;
}

void write_wo_csv(const std::string& path, const std::vector<WoStudyRow>& rows) {
  std::ostringstream out;
  out << "brdf,map,method,wo_resolution,offset,mean_error,max_error\n";
  for (const WoStudyRow& r : rows)
    out << r.brdf << "," << r.map << "," << r.method << "," << r.wo_resolution << "," << r.offset
        << "," << r.mean_error << "," << r.max_error << "\n";
  write_file_atomically(path, std::as_bytes(std::span(out.view().data(), out.view().size())));
}

void write_wo_sources_csv(const std::string& path, const std::vector<WoErrorSources>& rows) {
  std::ostringstream out;
  out << "brdf,wo_resolution,texels,table_tree,capture_tree,interpolation,total,bilinear_total\n";
  for (const WoErrorSources& r : rows)
    out << r.brdf << "," << r.wo_resolution << "," << r.texels << "," << r.table_tree << ","
        << r.capture_tree << "," << r.interpolation << "," << r.total << "," << r.bilinear_total
        << "\n";
  write_file_atomically(path, std::as_bytes(std::span(out.view().data(), out.view().size())));
}

}  // namespace basis
