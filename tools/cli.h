// Glue shared by the command-line tools: exit codes, one-line errors, interruption, progress.
#pragma once

#include <tbb/task_arena.h>
#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "basis/core/shard.h"
#include "basis/core/task.h"
#include "basis/core/vector.h"

namespace basis::cli {

// Exit statuses of every tool.
inline constexpr int kExitOk = 0;
inline constexpr int kExitBadData = 1;   // unreadable, corrupt or inconsistent input; I/O errors
inline constexpr int kExitBadUsage = 2;  // flags or arguments the tool cannot accept
inline constexpr int kExitInterrupted = 130;

// Parses the command line and runs `body`, turning every failure into one line on stderr
// ("TOOL: problem") and the exit statuses above. SIGINT and SIGTERM set the flag returned by
// interrupt_flag(); long operations stop at their next check and the tool exits 130 without
// writing output.
int run(CLI::App& app, int argc, char** argv, const std::function<void()>& body);

// The flag set by SIGINT / SIGTERM once run() has installed its handlers.
const std::atomic<bool>& interrupt_flag();

// Writes results to standard output. Where it cannot take them (a full disk, a file over its
// size limit, a pipe whose reader left while SIGPIPE is ignored), throws std::runtime_error
// "standard output: REASON; results lost" at once, with the failed write's own reason, so that
// the tool stops instead of working on.
void write_standard_output(std::string_view text);
// Flushes what write_standard_output left in standard output's buffer; the same error where the
// output refuses it (so that the last block's failure keeps its reason too).
void flush_standard_output();

// Thrown by tools for bad usage detected after parsing (exit status 2).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A TaskControl that draws a progress bar on stderr when it is a terminal (and `quiet` is
// false) and stops on interruption.
class ProgressBar {
 public:
  ProgressBar(std::string label, bool quiet);
  ~ProgressBar();
  const TaskControl& control() const { return control_; }
  // Prints one line on stderr on a line of its own: the bar, when drawn, is cleared first and
  // redrawn at the next report.
  void print_line(const std::string& line) const;
  void finish();

 private:
  std::string label_;
  bool enabled_;
  std::chrono::steady_clock::time_point start_;
  std::atomic<long long> last_draw_ms_{-1000};
  TaskControl control_;
};

// A task arena of `threads` workers (0: all cores) for the tools' --threads flag.
std::unique_ptr<tbb::task_arena> thread_arena(int threads);

// Parses --shard "I/N" for a run of `total` points (or results, as `what` names them): a shard
// of the run that leaves none empty. Throws UsageError naming the option.
Shard parse_shard_option(const std::string& text, std::uint64_t total, const std::string& what);

// Checks for numeric flags: a finite number; one >= 0; one > 0. CLI11's own ranges and signs let
// NaN through (every comparison with it is false) and print the largest double in full; chain
// finite_number() before a range.
CLI::Validator finite_number();
CLI::Validator non_negative_number();
CLI::Validator positive_number();
// A number from `lowest` to `highest` (for flags whose larger values would overflow the work they
// scale, such as a tolerance or an angle).
CLI::Validator number_between(double lowest, double highest);
// A whole number from 0 to 2^64 - 1, as written (CLI11 wraps "-1" and saturates larger ones).
CLI::Validator unsigned_number();

// A file a tool reads or writes, with the flag or argument that named it.
struct NamedPath {
  std::string option;
  std::string path;
  // What the file is, in messages, when not "the file OPTION reads".
  std::string what = {};
};
// Throws UsageError when an output is the same file as an input (links and relative paths
// resolved, for files that exist; an input manifest's shards and their checksums count as
// inputs), which writing it would destroy, or when two outputs name the same file, so that one
// would silently replace the other. Empty paths are skipped.
void check_outputs_spare_inputs(const std::vector<NamedPath>& outputs,
                                const std::vector<NamedPath>& inputs);

// Throws FileError naming `path` when an output cannot go there, checked before any work is
// done: its folder is missing, or it is a folder itself. Empty paths are skipped.
void check_output_place(const std::string& path);
// The extension of a path's file name (".PNG" gives ".png"; "" when it has none).
std::string lower_case_extension(const std::string& path);
// Throws UsageError unless `path` (given to `option`) is empty or names a PNG file (.png): the
// image is written after the work, and its format is chosen by that name.
void check_png_name(const std::string& path, const std::string& option);

// Parses "X,Y,Z" into three finite numbers; throws UsageError naming the option.
Vec3 parse_triple(const std::string& text, const std::string& option);
// Parses "X,Y,Z" into the unit vector along it, whatever its length (1e-300 or 1e300 alike);
// throws UsageError naming the option for a zero vector.
Vec3 parse_direction(const std::string& text, const std::string& option);

}  // namespace basis::cli
