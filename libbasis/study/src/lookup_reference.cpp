#include "basis/study/lookup_reference.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <initializer_list>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "basis/brdf/brdf_table.h"
#include "basis/brdf/table_lookup.h"
#include "basis/core/dense.h"
#include "basis/core/hemisphere.h"
#include "basis/io/image_file.h"
#include "basis/lighting/capture.h"
#include "basis/lighting/capture_inputs.h"
#include "basis/lighting/embree_scene.h"
#include "basis/lighting/mesh.h"
#include "basis/lighting/shading.h"

namespace basis {

CaptureInputs open_capture_inputs(const CaptureRecipe& recipe) {
  CaptureInputs inputs{recipe.environment.empty()
                           ? Environment::constant(recipe.constant)
                           : Environment(read_image(recipe.environment), recipe.rotate_z_degrees,
                                         recipe.environment),
                       nullptr};
  std::optional<TriangleMesh> mesh;
  if (!recipe.scene.empty()) mesh = read_obj(recipe.scene);
  if (!recipe.inputs_checksum.empty() &&
      capture_inputs_checksum(inputs.environment, mesh ? &*mesh : nullptr) !=
          recipe.inputs_checksum) {
    std::string what;
    if (!recipe.environment.empty()) what = "the map " + recipe.environment;
    if (!recipe.scene.empty())
      what += (what.empty() ? "the scene " : " or the scene ") + recipe.scene;
    if (what.empty()) what = "the constant light";
    throw FileError(what +
                    " changed since the capture: what it holds no longer has the "
                    "recorded checksum");
  }
  if (mesh) inputs.scene = std::make_unique<EmbreeScene>(*mesh);
  return inputs;
}

std::vector<Rgb> reference_lookups(const QtFile& table_file, const QtFile& captures_file,
                                   const Vec3& wo, const Brdf* light_brdf,
                                   WoInterpolation interpolation, const TaskControl& control) {
  return reference_lookups(table_file, captures_file,
                           PointRange{0, captures_file.captures().size()}, wo, light_brdf,
                           interpolation, control);
}

std::vector<Rgb> reference_lookups(const QtFile& table_file, const QtFile& captures_file,
                                   PointRange points, const Vec3& wo, const Brdf* light_brdf,
                                   WoInterpolation interpolation, const TaskControl& control) {
  const BrdfTableView table = table_file.brdf_table();
  const CaptureSetView captures = captures_file.captures();
  if (points.end() > captures.size())
    throw std::invalid_argument("captures " + std::to_string(points.first) + " .. " +
                                std::to_string(points.end()) + " of a set of " +
                                std::to_string(captures.size()));
  // Inputs recorded in the files, read again: a failure names the file that recorded them.
  const auto from_the_current_folder = [](std::initializer_list<std::string> paths) {
    for (const std::string& p : paths)
      if (!p.empty() && std::filesystem::path(p).is_relative())
        return std::string("; relative paths are read from the current folder");
    return std::string();
  };
  const BrdfSpec spec = [&] {
    try {
      return table_brdf(table_file);
    } catch (const FileError& e) {
      const std::vector<std::string>& sources = table_file.provenance().sources;
      throw FileError(table_file.name() + ": cannot read the BRDF it was tabulated from (" +
                      e.what() + ")" +
                      from_the_current_folder({sources.empty() ? std::string() : sources[0]}));
    }
  }();
  const CaptureRecipe recipe = capture_recipe(captures_file);
  if (recipe.options.resolution != table.trees.shape().resolution)
    throw std::invalid_argument(table_file.name() + " and " + captures_file.name() +
                                ": a reference needs the table and the captures at one "
                                "resolution (" +
                                std::to_string(table.trees.shape().resolution) + " and " +
                                std::to_string(recipe.options.resolution) + ")");
  const CaptureInputs inputs = [&] {
    try {
      return open_capture_inputs(recipe);
    } catch (const FileError& e) {
      // Recorded paths are as capture2qt was given them: relative ones from its folder.
      throw FileError(captures_file.name() + ": cannot read what it was captured from (" +
                      e.what() + ")" + from_the_current_folder({recipe.environment, recipe.scene}));
    }
  }();
  // The entries around wo re-tabulated (with their derivatives over wo when the table has
  // them), each combined as the lookup weighs its groups.
  BrdfTableOptions options;
  options.wo_resolution = table.wo_resolution;
  options.wi_resolution = table.trees.shape().resolution;
  options.wo_derivatives = table.has_wo_derivatives();
  std::vector<Grid> entries;
  for (const TableTap& tap : lookup_taps(table, wo, interpolation))
    if (tap.reads_anything())
      entries.push_back(
          combine_groups(tabulate_table_entry(spec.brdf, tap.i, tap.j, options), tap.weights));
  // The capture's own record of whether it kept its lights apart.
  CaptureOptions capture_options = recipe.options;
  capture_options.compact_lights = captures.light_offsets.empty()
                                       ? CaptureOptions::CompactLights::splatted
                                       : CaptureOptions::CompactLights::apart;
  std::vector<Rgb> out(points.count);
  std::atomic<std::size_t> done{0};
  tbb::parallel_for(std::size_t(0), std::size_t(points.count), [&](std::size_t i) {
    control.check();
    const std::size_t k = points.first + i;
    const Capture c = capture(inputs.environment, inputs.scene.get(), captures.positions[k],
                              captures.frame(k), capture_options, recipe.first_index() + k);
    Rgb sum{0, 0, 0};
    for (const Grid& entry : entries) {
      const Rgb d = dense_convolve_naive(entry, c.texels);
      for (int ch = 0; ch < 3; ++ch)
        sum[ch] += float(std::numbers::pi * d[ch]);
    }
    // Directional lights: f at the light (the BRDF itself, or the entries' texels there).
    for (const DirectionalLight& light : c.lights) {
      const Vec3& wi = light.direction;
      Color f{0, 0, 0};
      if (light_brdf) {
        f = evaluate(*light_brdf, wi, light_outgoing(wo));
      } else {
        for (const Grid& entry : entries) {
          const auto [x, y] = cosine_hemisphere_texel(wi, entry.resolution);
          for (int ch = 0; ch < 3; ++ch)
            f[ch] += entry.at(0, std::min(ch, entry.channels - 1), x, y);
        }
      }
      for (int ch = 0; ch < 3; ++ch)
        sum[ch] += float(f[ch] * light.energy[ch] * wi.z());
    }
    out[i] = sum;
    control.report(++done, points.count);
  });
  return out;
}

}  // namespace basis
