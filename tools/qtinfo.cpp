// qtinfo: what a .qt file holds, and a picture of one of its trees.
#include <iostream>

#include "basis/core/hemisphere.h"
#include "basis/core/version.h"
#include "basis/format/qt_file.h"
#include "basis/format/qt_manifest.h"
#include "basis/format/qt_summary.h"
#include "basis/io/image_file.h"
#include "basis/io/picture.h"
#include "cli.h"

namespace {

// The circles qtinfo draws on a capture: its directional lights, where they fall.
std::vector<basis::Vec2> light_markers(const basis::CaptureSetView& captures, std::size_t k) {
  std::vector<basis::Vec2> markers;
  for (const basis::DirectionalLight& l : captures.lights_of(k))
    markers.push_back(basis::cosine_hemisphere_to_square(l.direction));
  return markers;
}

// A manifest: the summary over its shards, and a picture of one capture (--index counts over
// the whole set).
void describe_manifest(const std::string& input, bool json, const std::string& png, int index,
                       int group, int size) {
  using basis::cli::UsageError;
  const basis::CaptureManifest manifest = basis::read_manifest(input);
  // Checked before anything is printed: captures have one group and no entries.
  if (group > 0)
    throw UsageError("--group " + std::to_string(group) + " but the captures hold 1 group");
  const std::uint64_t k = index < 0 ? 0 : std::uint64_t(index);
  if (k >= manifest.total_points)
    throw UsageError("--index " + std::to_string(index) + " but the set holds " +
                     std::to_string(manifest.total_points) + " captures");
  {
    basis::cli::ProgressBar progress("qtinfo", false);
    const std::string text = json ? basis::summary_json(manifest, progress.control()) + "\n"
                                  : basis::summary_text(manifest, progress.control());
    progress.finish();
    std::cout << text;
  }
  if (png.empty()) return;
  basis::CaptureSource source = basis::CaptureSource::open(input);
  const std::size_t shard = source.shard_of(k);
  const basis::QtFile& file = source.shard(shard);
  const std::size_t local = k - source.shard_points(shard).first;
  const basis::PackedTreeView tree = file.trees().tree(local);
  if (group >= tree.shape().groups)
    throw UsageError("--group " + std::to_string(group) + " but the trees hold " +
                     std::to_string(tree.shape().groups) + " groups");
  basis::write_image(
      png,
      basis::draw_tree(
          tree, {.size = size, .group = group, .markers = light_markers(file.captures(), local)}));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Describe a .qt file: its kind (tree, BRDF table, capture set), resolution, channels, "
      "tolerance, node counts per tree and per level, storage against dense grids, and where it "
      "came from. Optionally draw one tree as a PNG: the reconstructed function over the unit "
      "square (u right, v down) with the cells of the tree outlined, and a capture's directional "
      "lights (a sun kept apart) circled in yellow.",
      "qtinfo");
  std::string input, png, entry;
  int index = -1, group = 0, size = 512;
  bool json = false;
  app.add_option("file", input,
                 "the .qt file (at most 2 GiB), or a manifest of a capture set's shards (qtmerge "
                 "--manifest): every shard is checked and the facts are added up over them")
      ->required();
  app.add_flag("--json", json, "print the summary as JSON for scripts");
  app.add_option("--png", png, "draw a tree into this PNG file");
  app.add_option("--entry", entry,
                 "BRDF table entry I,J to draw (parabolic grid indices; default: the entry "
                 "nearest the normal)");
  app.add_option("--index", index, "capture (or tree) index to draw; default 0")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--group", group,
                 "what to draw of a BRDF table entry: 0 f, 1 and 2 its tilt derivatives about "
                 "the tangent and the bitangent")
      ->check(CLI::Range(0, 2));
  app.add_option("--size", size, "picture size in pixels")->check(CLI::Range(16, 8192));
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    using basis::cli::UsageError;
    basis::cli::check_outputs_spare_inputs({{"--png", png}}, {{"file", input}});
    if (png.empty() && (!entry.empty() || index >= 0 || group > 0 || app.count("--size") > 0))
      throw UsageError("--entry, --index, --group and --size shape the picture --png draws");
    if (!entry.empty() && index >= 0)
      throw UsageError(
          "--entry (a table's entry) and --index (a capture or tree) exclude each "
          "other");
    basis::cli::check_output_place(png);
    basis::cli::check_png_name(png, "--png");
    if (basis::is_manifest(input)) {
      if (!entry.empty())
        throw UsageError(
            "--entry picks a BRDF table's entry; a manifest lists captures: pick "
            "one with --index");
      return describe_manifest(input, json, png, index, group, size);
    }
    const basis::QtFile file = basis::QtFile::load(input);
    // The tree to draw is chosen, and checked, before anything is printed.
    basis::PackedTreeView tree = file.tree();
    if (file.kind() == basis::QtKind::brdf_table) {
      if (index >= 0)
        throw UsageError(
            "--index picks a capture or a tree; a table's entries are picked with "
            "--entry I,J");
      const basis::BrdfTableView table = file.brdf_table();
      int i = (table.wo_resolution - 1) / 2, j = i;
      if (!entry.empty()) {
        char comma = 0;
        std::istringstream in(entry);
        if (!(in >> i >> comma >> j) || comma != ',' || !(in >> std::ws).eof())
          throw UsageError("--entry expects I,J, got '" + entry + "'");
      }
      if (i < 0 || j < 0 || i >= table.wo_resolution || j >= table.wo_resolution)
        throw UsageError("--entry " + std::to_string(i) + "," + std::to_string(j) +
                         " outside the " + std::to_string(table.wo_resolution) + " x " +
                         std::to_string(table.wo_resolution) + " table");
      if (group > 0 && !table.has_tilt())
        throw UsageError("--group " + std::to_string(group) +
                         " but the table holds no tilt derivatives");
      tree = group > 0 ? table.tilt_entry(i, j) : table.entry(i, j);
      if (group > 0) --group;  // tilt trees hold the two derivatives as groups 0 and 1
    } else {
      if (!entry.empty())
        throw UsageError(
            "--entry picks a BRDF table's entry; this file holds " +
            std::string(file.kind() == basis::QtKind::capture_set ? "captures" : "trees") +
            ": pick one with --index");
      if (index >= 0) {
        if (std::size_t(index) >= file.trees().size())
          throw UsageError("--index " + std::to_string(index) + " but the file holds " +
                           std::to_string(file.trees().size()) + " trees");
        tree = file.trees().tree(std::size_t(index));
      }
    }
    if (group >= tree.shape().groups)
      throw UsageError("--group " + std::to_string(group) + " but the trees hold " +
                       std::to_string(tree.shape().groups) + " group" +
                       (tree.shape().groups == 1 ? "" : "s"));
    std::cout << (json ? basis::summary_json(file) + "\n" : basis::summary_text(file));
    if (png.empty()) return;
    // A capture's directional lights are circled where they fall.
    std::vector<basis::Vec2> markers;
    if (file.kind() == basis::QtKind::capture_set)
      markers = light_markers(file.captures(), std::size_t(index < 0 ? 0 : index));
    basis::write_image(png,
                       basis::draw_tree(tree, {.size = size, .group = group, .markers = markers}));
  });
}
