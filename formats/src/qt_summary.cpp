#include "basis/format/qt_summary.h"
#include "basis/core/projection.h"
#include "basis/format/qt_merge.h"
#include "basis/io/json_text.h"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

namespace basis {

namespace {

using nlohmann::ordered_json;

ordered_json summarise(const QtFile& file) {
  const TreeSetView trees = file.trees();
  const PackedShape& s = trees.shape();
  ordered_json j;
  j["file"] = file.name();
  j["bytes"] = file.byte_size();
  j["format_version"] = file.format_version();
  j["checksum_verified"] = file.checksum_verified();
  j["kind"] = to_string(file.kind());
  j["mapping"] = "cosine-weighted concentric";
  j["trees"] = trees.size();
  j["resolution"] = s.resolution;
  j["channels"] = s.channels;
  j["groups"] = s.groups;
  j["bounds"] = s.bounds == BoundKind::l2 ? "l2 (RMS deviation)" : "linf (largest deviation)";
  j["zero_copy"] = file.zero_copy();
  const ProjectionOptions p = file.projection();
  j["tolerance"] = {{"value", p.tolerance},
                    {"mode", p.mode == ProjectionOptions::Mode::relative ? "relative" : "absolute"},
                    {"max_depth", p.max_depth},
                    {"floor", p.local_floor}};

  std::size_t total = 0, smallest = SIZE_MAX, largest = 0;
  std::vector<long long> histogram;
  for (std::size_t i = 0; i < trees.size(); ++i) {
    const PackedTreeView t = trees.tree(i);
    const std::size_t n = std::size_t(t.node_count());
    total += n;
    smallest = std::min(smallest, n);
    largest = std::max(largest, n);
    const std::vector<int> h = depth_histogram(t);
    if (histogram.size() < h.size()) histogram.resize(h.size(), 0);
    for (std::size_t k = 0; k < h.size(); ++k)
      histogram[k] += h[k];
  }
  j["nodes"] = {{"total", total},
                {"min", smallest},
                {"mean", double(total) / double(trees.size())},
                {"max", largest},
                {"per_level", histogram}};
  // As stored in the file; a set restored on loading takes more in memory.
  const double tree_bytes = double(file.stored_tree_bytes());
  const double dense_bytes =
      double(trees.size()) * s.resolution * s.resolution * s.channels * s.groups * sizeof(float);
  j["storage"] = {{"tree_bytes", tree_bytes},
                  {"memory_bytes", double(trees.bytes())},
                  {"dense_bytes", dense_bytes},
                  {"compression", dense_bytes / tree_bytes}};
  if (file.kind() == QtKind::brdf_table) {
    const BrdfTableView table = file.brdf_table();
    const double tilt_bytes = double(table.tilt.bytes());
    j["brdf_table"] = {{"wo_resolution", table.wo_resolution},
                       {"model", file.brdf_model()},
                       {"spec", file.brdf_spec()},
                       {"tilt_trees", table.tilt.size()},
                       {"tilt_resolution", table.has_tilt() ? table.tilt.shape().resolution : 0},
                       {"tilt_nodes", table.has_tilt() ? table.tilt.total_nodes() : 0},
                       {"tilt_bytes", tilt_bytes}};
  }
  if (file.kind() == QtKind::capture_set) {
    const CaptureSetView c = file.captures();
    Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
    for (const Vec3& q : c.positions) {
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
    std::size_t lit = 0;
    for (std::size_t k = 0; k < c.size(); ++k)
      lit += !c.lights_of(k).empty();
    j["captures"] = {{"points", c.size()},
                     {"bounds_min", {lo.x(), lo.y(), lo.z()}},
                     {"bounds_max", {hi.x(), hi.y(), hi.z()}},
                     {"lights", c.lights.size()},
                     {"points_with_lights", lit}};
  }
  const Provenance prov = file.provenance();
  j["provenance"] = {{"tool", prov.tool},
                     {"tool_version", prov.tool_version},
                     {"parameters", prov.parameters},
                     {"sources", prov.sources}};
  return j;
}

std::string bytes_text(double bytes) {
  char buffer[64];
  if (bytes >= 1 << 20)
    std::snprintf(buffer, sizeof buffer, "%.2f MiB", bytes / (1 << 20));
  else if (bytes >= 1 << 10)
    std::snprintf(buffer, sizeof buffer, "%.1f KiB", bytes / (1 << 10));
  else
    std::snprintf(buffer, sizeof buffer, "%.0f B", bytes);
  return buffer;
}

// The summary of a manifest's capture set: its shards' summaries added up, the run's provenance,
// and the shards themselves.
ordered_json summarise(const CaptureManifest& manifest, const TaskControl& control) {
  ordered_json total;
  ordered_json shards = ordered_json::array();
  for (std::size_t k = 0; k < manifest.shards.size(); ++k) {
    control.check();
    const QtFile shard = open_manifest_shard(manifest, k);
    const ordered_json j = summarise(shard);
    const ManifestShard& entry = manifest.shards[k];
    shards.push_back({{"file", entry.file},
                      {"points", entry.points},
                      {"bytes", entry.bytes},
                      {"xxh128", entry.xxh128},
                      {"checked", true}});
    control.report(k + 1, manifest.shards.size());
    if (k == 0) {
      total = j;
      total["file"] = manifest.path;
      const Provenance run = run_provenance(shard);
      total["provenance"]["parameters"] = run.parameters;
      continue;
    }
    auto add = [](ordered_json& into, const ordered_json& from) {
      into = into.get<double>() + from.get<double>();
    };
    total["bytes"] = total["bytes"].get<std::uint64_t>() + j["bytes"].get<std::uint64_t>();
    total["trees"] = total["trees"].get<std::uint64_t>() + j["trees"].get<std::uint64_t>();
    total["zero_copy"] = total["zero_copy"].get<bool>() && j["zero_copy"].get<bool>();
    total["checksum_verified"] =
        total["checksum_verified"].get<bool>() && j["checksum_verified"].get<bool>();
    ordered_json& nodes = total["nodes"];
    nodes["total"] = nodes["total"].get<std::uint64_t>() + j["nodes"]["total"].get<std::uint64_t>();
    nodes["min"] =
        std::min(nodes["min"].get<std::uint64_t>(), j["nodes"]["min"].get<std::uint64_t>());
    nodes["max"] =
        std::max(nodes["max"].get<std::uint64_t>(), j["nodes"]["max"].get<std::uint64_t>());
    nodes["mean"] =
        double(nodes["total"].get<std::uint64_t>()) / double(total["trees"].get<std::uint64_t>());
    ordered_json& levels = nodes["per_level"];
    for (std::size_t l = 0; l < j["nodes"]["per_level"].size(); ++l) {
      if (l >= levels.size()) levels.push_back(0);
      levels[l] = levels[l].get<long long>() + j["nodes"]["per_level"][l].get<long long>();
    }
    ordered_json& storage = total["storage"];
    add(storage["tree_bytes"], j["storage"]["tree_bytes"]);
    add(storage["memory_bytes"], j["storage"]["memory_bytes"]);
    add(storage["dense_bytes"], j["storage"]["dense_bytes"]);
    storage["compression"] =
        storage["dense_bytes"].get<double>() / storage["tree_bytes"].get<double>();
    ordered_json& c = total["captures"];
    const ordered_json& d = j["captures"];
    c["points"] = c["points"].get<std::uint64_t>() + d["points"].get<std::uint64_t>();
    for (int i = 0; i < 3; ++i) {
      c["bounds_min"][i] =
          std::min(c["bounds_min"][i].get<double>(), d["bounds_min"][i].get<double>());
      c["bounds_max"][i] =
          std::max(c["bounds_max"][i].get<double>(), d["bounds_max"][i].get<double>());
    }
    c["lights"] = c["lights"].get<std::uint64_t>() + d["lights"].get<std::uint64_t>();
    c["points_with_lights"] =
        c["points_with_lights"].get<std::uint64_t>() + d["points_with_lights"].get<std::uint64_t>();
  }
  total["manifest"] = {
      {"path", manifest.path}, {"total_points", manifest.total_points}, {"shards", shards}};
  return total;
}

std::string render_text(const ordered_json& j) {
  std::ostringstream out;
  out << "file         " << j["file"].get<std::string>() << " ("
      << bytes_text(j["bytes"].get<double>());
  if (j.contains("manifest")) out << " in " << j["manifest"]["shards"].size() << " shard files";
  out << ", format " << j["format_version"].get<std::uint32_t>()
      << (j.value("checksum_verified", false) ? ", checksum verified" : "") << ")\n";
  if (j.contains("manifest")) {
    const auto& shards = j["manifest"]["shards"];
    out << "shards       a manifest of " << shards.size()
        << " files, each checked (size, checksum, shard of the run):";
    for (std::size_t k = 0; k < shards.size() && k < 8; ++k)
      out << (k ? ", " : " ") << shards[k]["file"].get<std::string>() << " ("
          << shards[k]["points"].get<std::uint64_t>() << ")";
    if (shards.size() > 8) out << ", ...";
    out << "\n";
  }
  out << "kind         " << j["kind"].get<std::string>();
  if (j.contains("brdf_table")) {
    const int m = j["brdf_table"]["wo_resolution"];
    out << ", model " << j["brdf_table"]["model"].get<std::string>() << ", " << m << " x " << m
        << " outgoing directions (parabolic grid)";
  }
  if (j.contains("captures"))
    out << ", " << j["captures"]["points"].get<std::size_t>() << " points";
  out << "\n";
  const int n = j["resolution"], channels = j["channels"], groups = j["groups"];
  out << "trees        " << j["trees"].get<std::size_t>() << " over " << n << " x " << n
      << " texels of the cosine-weighted concentric map, " << channels
      << (channels == 1 ? " channel" : " channels");
  if (groups == 3 && j.contains("brdf_table"))
    out << ", 3 groups (f, and its derivatives over wo along s and t per grid step)";
  else if (groups == 3)
    out << ", 3 groups";
  else if (groups > 1)
    out << ", " << groups << " groups";
  out << "\n";
  const auto& tol = j["tolerance"];
  out << "tolerance    ";
  if (tol["mode"] == "relative" && tol["floor"].get<double>() > 0)
    out << tol["value"].get<double>() * 100 << " % of each quadrant's value, at least of "
        << tol["floor"].get<double>() << " x each channel's mean";
  else if (tol["mode"] == "relative")
    out << tol["value"].get<double>() * 100 << " % of each channel's mean";
  else
    out << tol["value"].get<double>() << " (absolute)";
  const int depth = tol["max_depth"];
  out << ", max depth " << (depth == 0 ? std::string("full") : std::to_string(depth)) << "\n";
  const auto& nodes = j["nodes"];
  char line[256];
  std::snprintf(line, sizeof line,
                "nodes        %zu in all; per tree min %zu, mean %.1f, max %zu\n",
                nodes["total"].get<std::size_t>(), nodes["min"].get<std::size_t>(),
                nodes["mean"].get<double>(), nodes["max"].get<std::size_t>());
  out << line << "per level    ";
  const auto& levels = nodes["per_level"];
  for (std::size_t k = 0; k < levels.size(); ++k)
    out << (k ? ", " : "") << "L" << k << " " << levels[k].get<long long>();
  out << "\n";
  const auto& storage = j["storage"];
  std::string in_memory;
  if (storage["memory_bytes"].get<double>() != storage["tree_bytes"].get<double>())
    in_memory = " (" + bytes_text(storage["memory_bytes"]) + " in memory)";
  std::snprintf(line, sizeof line,
                "storage      %s of nodes and bounds in the file%s; dense grids %s; %.1fx "
                "smaller\n",
                bytes_text(storage["tree_bytes"]).c_str(), in_memory.c_str(),
                bytes_text(storage["dense_bytes"]).c_str(), storage["compression"].get<double>());
  out << line;
  if (j.contains("captures")) {
    const auto& lo = j["captures"]["bounds_min"];
    const auto& hi = j["captures"]["bounds_max"];
    std::snprintf(line, sizeof line, "bounds       (%g, %g, %g) .. (%g, %g, %g)\n",
                  lo[0].get<double>(), lo[1].get<double>(), lo[2].get<double>(),
                  hi[0].get<double>(), hi[1].get<double>(), hi[2].get<double>());
    out << line;
    out << "lights       " << j["captures"]["lights"].get<std::size_t>()
        << " directional (compact lights kept apart) at "
        << j["captures"]["points_with_lights"].get<std::size_t>() << " points\n";
  }
  if (j.contains("brdf_table")) {
    const auto& t = j["brdf_table"];
    if (t["tilt_trees"].get<std::size_t>() > 0) {
      std::snprintf(
          line, sizeof line,
          "tilt         %zu trees of two tilt derivatives over %d x %d texels, %zu nodes, "
          "%s (rotation compensation)\n",
          t["tilt_trees"].get<std::size_t>(), t["tilt_resolution"].get<int>(),
          t["tilt_resolution"].get<int>(), t["tilt_nodes"].get<std::size_t>(),
          bytes_text(t["tilt_bytes"].get<double>()).c_str());
      out << line;
    } else {
      out << "tilt         none (no rotation compensation)\n";
    }
  }
  const auto& prov = j["provenance"];
  if (!prov["tool"].get<std::string>().empty()) {
    out << "made by      " << prov["tool"].get<std::string>() << " "
        << prov["tool_version"].get<std::string>() << "\n";
    if (!prov["parameters"].get<std::string>().empty())
      out << "parameters   " << prov["parameters"].get<std::string>() << "\n";
    if (!prov["sources"].empty()) {
      out << "sources     ";
      for (const auto& s : prov["sources"])
        out << " " << s.get<std::string>();
      out << "\n";
    }
  }
  return out.str();
}

}  // namespace

std::string summary_json(const QtFile& file) {
  return json_text(summarise(file), 2);
}

std::string summary_text(const QtFile& file) {
  return render_text(summarise(file));
}

std::string summary_json(const CaptureManifest& manifest, const TaskControl& control) {
  return json_text(summarise(manifest, control), 2);
}

std::string summary_text(const CaptureManifest& manifest, const TaskControl& control) {
  return render_text(summarise(manifest, control));
}

}  // namespace basis
