// qtmerge: the shard files of a sharded capture run (capture2qt --shard) joined into the one
// capture set a single process writes, or listed in a manifest that the tools read in their place.
#include <tbb/parallel_for.h>
#include <cstdio>
#include <iostream>

#include <atomic>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>

#include "basis/core/version.h"
#include "basis/format/qt_manifest.h"
#include "basis/format/qt_merge.h"
#include "basis/format/qt_shard.h"
#include "basis/io/atomic_file.h"
#include "basis/io/json_text.h"
#include "cli.h"

namespace {

// Opens and checks `count` files in parallel (reading and checksumming them is what a merge
// costs); the first failure in the files' order is the one reported, whatever the threads did.
template <typename File>
std::vector<File> open_in_parallel(std::size_t count, int threads,
                                   const basis::TaskControl& control,
                                   const std::function<File(std::size_t)>& open) {
  std::vector<std::optional<File>> files(count);
  std::vector<std::string> errors(count);
  std::atomic<std::size_t> done{0};
  basis::cli::thread_arena(threads)->execute([&] {
    tbb::parallel_for(std::size_t(0), count, [&](std::size_t k) {
      if (control.cancel && control.cancel->load()) return;
      try {
        files[k].emplace(open(k));
      } catch (const std::exception& e) {
        errors[k] = e.what();
      }
      control.report(++done, count);
    });
  });
  control.check();
  std::vector<File> opened;
  for (std::size_t k = 0; k < count; ++k) {
    if (!errors[k].empty()) throw basis::FileError(errors[k]);
    opened.push_back(std::move(*files[k]));
  }
  return opened;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Join or list the shard files of a sharded capture run (capture2qt --shard I/N).\n"
      "  qtmerge SHARD.qt... -o OUT.qt: one capture set, byte for byte the file one process "
      "capturing every point writes; refused in one line when it would pass the 2 GiB one .qt "
      "file holds.\n"
      "  qtmerge SHARD.qt... --manifest OUT.qtm: a manifest, a small JSON file listing the shards "
      "in order with their point counts, sizes and checksum, which qtconvolve and qtinfo read "
      "wherever they read a capture set, one shard at a time.\n"
      "  qtmerge MANIFEST.qtm -o OUT.qt: the shards a manifest lists, joined.\n"
      "Shards may be given in any order (a shell glob): each records which shard it is. Every "
      "shard is checked first: its checksum (the OUT.xxh128 capture2qt writes beside it, or the "
      "manifest's), that it verifies as a .qt file, and that the shards are all of one run, "
      "each once, none missing. A problem is one line naming the file, and nothing is written.",
      "qtmerge");
  std::vector<std::string> inputs;
  std::string output, manifest_output;
  bool json = false, quiet = false;
  int threads = 0;
  app.add_option("inputs", inputs, "shard files of one run (any order), or one manifest")
      ->required();
  app.add_option("-o,--output", output, "write the joined capture set here");
  app.add_option("--manifest", manifest_output,
                 "write a manifest listing the shards here (shard files named relative to its "
                 "folder)");
  app.add_option("--threads", threads,
                 "shards read and checked at once (default: all cores; reading is what a merge "
                 "costs)")
      ->check(CLI::Range(1, 1024));
  app.add_flag("--json", json, "print what was written as JSON");
  app.add_flag("-q,--quiet", quiet, "no progress bar or summary (--json still prints)");
  app.set_version_flag("--version", basis::kVersion);

  return basis::cli::run(app, argc, argv, [&] {
    using basis::cli::UsageError;
    if (output.empty() && manifest_output.empty())
      throw UsageError("say what to write: -o OUT.qt, --manifest OUT.qtm, or both");
    std::vector<basis::cli::NamedPath> read;
    for (const std::string& path : inputs)
      read.push_back({"inputs", path});
    basis::cli::check_outputs_spare_inputs({{"-o", output}, {"--manifest", manifest_output}}, read);
    basis::cli::check_output_place(output);
    basis::cli::check_output_place(manifest_output);
    basis::cli::ProgressBar progress("qtmerge", quiet);
    const basis::TaskControl& control = progress.control();
    std::vector<basis::QtFile> manifest_shards;
    std::vector<basis::ShardFile> shard_files;
    std::vector<const basis::QtFile*> sets;
    std::uint64_t points = 0;
    if (inputs.size() == 1 && basis::is_manifest(inputs[0])) {
      if (!manifest_output.empty())
        throw UsageError("--manifest lists shard files; " + inputs[0] + " is a manifest already");
      const basis::CaptureManifest manifest = basis::read_manifest(inputs[0]);
      manifest_shards = open_in_parallel<basis::QtFile>(
          manifest.shards.size(), threads, control,
          [&](std::size_t k) { return basis::open_manifest_shard(manifest, k); });
      for (const basis::QtFile& f : manifest_shards)
        sets.push_back(&f);
      points = manifest.total_points;
    } else {
      for (const std::string& input : inputs)
        if (basis::is_manifest(input))
          throw UsageError(input + ": a manifest; give shard files, or one manifest alone");
      shard_files = open_in_parallel<basis::ShardFile>(
          inputs.size(), threads, control,
          [&](std::size_t k) { return basis::open_shard_file(inputs[k]); });
      basis::order_shards_of_one_run(shard_files);
      for (const basis::ShardFile& s : shard_files)
        sets.push_back(&s.file);
      points = shard_files.front().recipe.shard->total_points;
    }
    progress.finish();

    // Both outputs are made, then written to temporary files, and only then put in place: a
    // refusal (past 2 GiB) or a failed write of either leaves neither (only a failure of the
    // final renames themselves could leave one).
    nlohmann::ordered_json report = {{"shards", sets.size()}, {"points", points}};
    std::vector<std::byte> joined;
    if (!output.empty()) {
      joined = basis::merge_capture_sets(sets, basis::run_provenance(*sets.front()), output);
      control.check();
    }
    std::string manifest_text;
    if (!manifest_output.empty())
      manifest_text = basis::manifest_json(basis::make_manifest(shard_files, manifest_output));
    std::optional<basis::AtomicFileWriter> joined_file, manifest_file;
    if (!output.empty()) {
      joined_file.emplace(output);
      joined_file->write(joined);
    }
    if (!manifest_output.empty()) {
      manifest_file.emplace(manifest_output);
      manifest_file->write(manifest_text);
    }
    control.check();
    if (joined_file) {
      joined_file->commit();
      report["output"] = output;
      report["bytes"] = joined.size();
      if (!quiet && !json)
        std::printf("%s: %zu shards joined, %llu captures, %.2f MiB\n", output.c_str(), sets.size(),
                    static_cast<unsigned long long>(points), double(joined.size()) / (1 << 20));
    }
    if (manifest_file) {
      manifest_file->commit();
      report["manifest"] = manifest_output;
      if (!quiet && !json)
        std::printf("%s: a manifest of %zu shards, %llu points\n", manifest_output.c_str(),
                    sets.size(), static_cast<unsigned long long>(points));
    }
    if (json) std::cout << basis::json_text(report) << "\n";
  });
}
