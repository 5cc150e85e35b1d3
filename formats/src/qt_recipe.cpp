#include "basis/format/qt_recipe.h"
#include "basis/brdf/measured.h"
#include "basis/io/checksum.h"
#include "basis/io/json_text.h"

#include <charconv>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

namespace basis {

BrdfSpec table_brdf(const QtFile& table) {
  const std::string spec = table.brdf_spec();
  if (spec.empty()) throw FileError(table.name() + ": the table does not store its BRDF spec");
  const Provenance p = table.provenance();
  const std::string folder = p.sources.empty()
                                 ? std::string()
                                 : std::filesystem::path(p.sources[0]).parent_path().string();
  BrdfSpec parsed = parse_brdf_spec(spec, table.name() + " (stored spec)", folder);
  // A measured BRDF's data file read now must be the one the table was made from: another
  // would light the directional lights with other data than the table's texels hold.
  const nlohmann::json parameters = nlohmann::json::parse(p.parameters, nullptr, false);
  if (parameters.is_object() && parameters.contains("data_checksum") &&
      parameters["data_checksum"] != brdf_data_checksum(parsed.brdf))
    throw FileError(table.name() + ": the data file its spec names (" + parsed.data_file +
                    ") has changed since the table was made from it (its checksum differs); "
                    "make the table again with brdf2qt");
  // The spec answers for the table's directional lights: one that is not the table's BRDF
  // (a damaged file) would light them with another.
  const int channels = table.trees().shape().channels;
  if (parsed.model != table.brdf_model() || channel_count(parsed.brdf) != channels)
    throw FileError(table.name() + ": its stored spec (" + parsed.model + ", " +
                    std::to_string(channel_count(parsed.brdf)) +
                    " channels) is not its table's BRDF (" + table.brdf_model() + ", " +
                    std::to_string(channels) +
                    "); the file is damaged: make it again with brdf2qt");
  return parsed;
}

namespace {

// The shortest text that reads back as the same double.
std::string shortest(double v) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, v).ptr;
  return std::string(text, end);
}

}  // namespace

BrdfTableOptions table_options(const BrdfSpec& spec) {
  BrdfTableOptions options;
  options.wo_resolution = spec.wo_resolution.value_or(default_wo_resolution(spec.brdf));
  options.wi_resolution = spec.wi_resolution.value_or(options.wi_resolution);
  options.projection.tolerance = spec.tolerance.value_or(options.projection.tolerance);
  return options;
}

std::string table_parameters(const BrdfTableOptions& options, const Brdf& brdf) {
  const bool absolute = options.projection.mode == ProjectionOptions::Mode::absolute;
  nlohmann::ordered_json j = {{"wo_res", options.wo_resolution},
                              {"wi_res", options.wi_resolution},
                              {"tolerance", options.projection.tolerance},
                              {"tolerance_floor", options.projection.local_floor},
                              {"wo_derivatives", options.wo_derivatives},
                              {"mode", absolute ? "absolute" : "relative"},
                              {"tilt_derivatives", options.tilt_derivatives},
                              {"bounds", options.bounds == BoundKind::linf ? "linf" : "l2"}};
  const std::string data_checksum = brdf_data_checksum(brdf);
  if (!data_checksum.empty()) j["data_checksum"] = data_checksum;
  return json_text(j);
}

std::string capture_parameters(const CaptureRecipe& r) {
  const bool apart = r.options.compact_lights == CaptureOptions::CompactLights::apart;
  const std::string constant =
      r.environment.empty()
          ? shortest(r.constant[0]) + "," + shortest(r.constant[1]) + "," + shortest(r.constant[2])
          : std::string();
  nlohmann::ordered_json j = {
      {"res", r.options.resolution},
      {"spp", r.options.strata * r.options.strata},
      {"tolerance", r.projection.tolerance},
      {"mode", r.projection.mode == ProjectionOptions::Mode::absolute ? "absolute" : "relative"},
      {"seed", r.options.seed},
      {"ray_offset", r.options.ray_offset},
      {"env", r.environment},
      {"env_rotate", r.rotate_z_degrees},
      {"env_constant", constant},
      {"scene", r.scene},
      {"lights", apart ? "apart" : "splatted"}};
  if (!r.inputs_checksum.empty()) j["inputs_xxh128"] = r.inputs_checksum;
  if (r.shard)
    j["shard"] = {{"index", r.shard->shard.index},
                  {"count", r.shard->shard.count},
                  {"total_points", r.shard->total_points}};
  // The recipe names its inputs so that they can be found again: a name that is not UTF-8
  // could not be written as itself.
  for (const std::string& name : {r.environment, r.scene})
    if (!json_holds_exactly(name))
      throw FileError(name +
                      ": a capture's provenance cannot record a file name that is not UTF-8");
  return j.dump();
}

std::string run_parameters(const std::string& parameters, const std::string& name) {
  nlohmann::ordered_json j;
  try {
    j = nlohmann::ordered_json::parse(parameters);
  } catch (const nlohmann::json::exception&) {
    throw FileError(name + ": unreadable capture parameters in its provenance");
  }
  if (!j.is_object()) throw FileError(name + ": unreadable capture parameters in its provenance");
  j.erase("shard");
  return json_text(j);
}

CaptureRecipe capture_recipe(const QtFile& captures) {
  // capture2qt and the Python module's capture() record their recipe; other writers do not.
  const Provenance p = captures.provenance();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(p.parameters);
  } catch (const nlohmann::json::exception&) {
    throw FileError(captures.name() + ": unreadable capture parameters in its provenance");
  }
  if (!j.is_object() || !j.contains("res"))
    throw FileError(captures.name() + ": its provenance (" + p.tool +
                    ") records no capture recipe, its inputs are unknown");
  CaptureRecipe r;
  r.projection = captures.projection();
  try {
    r.options.resolution = j.at("res").get<int>();
    if (r.options.resolution != captures.trees().shape().resolution)
      throw FileError(captures.name() + ": its provenance records captures of " +
                      std::to_string(r.options.resolution) + "², its trees are " +
                      std::to_string(captures.trees().shape().resolution) + "²");
    const long long spp = j.at("spp").get<long long>();
    if (spp < 1 || spp > 4096)
      throw FileError(captures.name() + ": its provenance records " + std::to_string(spp) +
                      " samples per texel, where captures take 1 to 4096");
    r.options.strata = 1;
    while (static_cast<long long>(r.options.strata) * r.options.strata < spp)
      ++r.options.strata;
    r.options.seed = j.at("seed").get<std::uint64_t>();
    r.options.ray_offset = j.at("ray_offset").get<double>();
    // Sets made before compact lights were kept apart splatted them.
    r.options.compact_lights = j.value("lights", std::string("splatted")) == "apart"
                                   ? CaptureOptions::CompactLights::apart
                                   : CaptureOptions::CompactLights::splatted;
    r.rotate_z_degrees = j.at("env_rotate").get<double>();
    const std::string constant = j.at("env_constant").get<std::string>();
    if (!constant.empty()) {
      char comma;
      std::istringstream in(constant);
      in >> r.constant[0] >> comma >> r.constant[1] >> comma >> r.constant[2];
    }
    r.environment = j.value("env", std::string());
    r.scene = j.value("scene", std::string());
    r.inputs_checksum = j.value("inputs_xxh128", std::string());
    if (!r.inputs_checksum.empty() && !is_checksum_text(r.inputs_checksum))
      throw FileError(captures.name() + ": its provenance records inputs checksum '" +
                      r.inputs_checksum + "', not 32 hex digits");
    if (j.contains("shard")) {
      const auto& s = j.at("shard");
      CaptureShard shard{{s.at("index").get<int>(), s.at("count").get<int>()},
                         s.at("total_points").get<std::uint64_t>()};
      if (shard.shard.count < 1 || shard.shard.count > kMaxShards || shard.shard.index < 0 ||
          shard.shard.index >= shard.shard.count)
        throw FileError(captures.name() + ": its provenance names shard " +
                        std::to_string(shard.shard.index) + "/" +
                        std::to_string(shard.shard.count) + ", which no run has");
      if (shard.points().count != captures.trees().size())
        throw FileError(captures.name() + ": holds " + std::to_string(captures.trees().size()) +
                        " captures where shard " + std::to_string(shard.shard.index) + "/" +
                        std::to_string(shard.shard.count) + " of " +
                        std::to_string(shard.total_points) + " points holds " +
                        std::to_string(shard.points().count));
      r.shard = shard;
    }
  } catch (const nlohmann::json::exception&) {
    throw FileError(captures.name() + ": incomplete capture parameters in its provenance");
  }
  return r;
}

}  // namespace basis
