#include "cli.h"

#include <sys/stat.h>
#include <tbb/info.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <limits>
#include <sstream>
#include <utility>

#include "basis/core/file_error.h"
#include "basis/format/qt_manifest.h"
#include "basis/io/checksum.h"

namespace basis::cli {

namespace {

// The only process-wide state of the tools: set from signal handlers.
std::atomic<bool> interrupted{false};

extern "C" void on_signal(int) {
  interrupted.store(true);
}

// Whether everything written to standard output reached it; errno says why not (a full device,
// a pipe whose reader left while SIGPIPE is ignored). A write that failed while the tool worked
// stops the stream's later writes, and so leaves no errno here: then, where the output is not a
// regular file, one byte more goes straight to it, whose results are lost anyway, to learn why
// (a file keeps what it has, and the message says only "write error"; qtconvolve's results go
// through write_standard_output and flush_standard_output, which keep the failed write's reason).
bool standard_output_written() {
  errno = 0;  // before the writes, so that a failed one's reason stays for the message
  std::cout.flush();
  const bool written = std::fflush(stdout) == 0 && !std::ferror(stdout) && !std::cout.fail();
  struct stat output {};
  if (!written && errno == 0 && std::ferror(stdout) && ::fstat(STDOUT_FILENO, &output) == 0 &&
      !S_ISREG(output.st_mode)) {
    [[maybe_unused]] const ssize_t probe = ::write(STDOUT_FILENO, "\n", 1);  // errno if it fails
  }
  return written;
}

std::string one_line(std::string text) {
  for (char& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  while (!text.empty() && text.back() == ' ')
    text.pop_back();
  return text;
}

}  // namespace

const std::atomic<bool>& interrupt_flag() {
  return interrupted;
}

namespace {

[[noreturn]] void standard_output_lost(int reason) {
  throw std::runtime_error(std::string("standard output: ") +
                           (reason != 0 ? std::strerror(reason) : "write error") +
                           "; results lost");
}

}  // namespace

void write_standard_output(std::string_view text) {
  errno = 0;
  if (std::fwrite(text.data(), 1, text.size(), stdout) != text.size() || std::ferror(stdout))
    standard_output_lost(errno);
}

void flush_standard_output() {
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) standard_output_lost(errno);
}

namespace {

// The first option of `app` or of its option groups given an empty value, or none.
const CLI::Option* option_given_empty(const CLI::App& app) {
  for (const CLI::Option* option : app.get_options())
    if (option->get_type_size() != 0 && option->count() > 0)
      for (const std::string& value : option->results())
        if (value.empty()) return option;
  for (const CLI::App* group : app.get_subcommands([](const CLI::App*) { return true; }))
    if (const CLI::Option* empty = option_given_empty(*group)) return empty;
  return nullptr;
}

}  // namespace

int run(CLI::App& app, int argc, char** argv, const std::function<void()>& body) {
  const std::string tool = app.get_name();
  // --help and --version print to standard output; one that cannot take them is an error.
  const auto printed = [&](int status) {
    if (standard_output_written()) return status;
    std::cerr << tool
              << ": standard output: " << (errno != 0 ? std::strerror(errno) : "write error")
              << "; help lost\n";
    return kExitBadData;
  };
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return printed(app.exit(e));
  } catch (const CLI::CallForAllHelp& e) {
    return printed(app.exit(e));
  } catch (const CLI::CallForVersion& e) {
    return printed(app.exit(e));
  } catch (const CLI::ParseError& e) {
    std::cerr << tool << ": " << one_line(e.what()) << " (see --help)\n";
    return kExitBadUsage;
  }
  // An empty value (-o "", an unset variable in a script) names no file, number or word; an
  // empty output name would otherwise fall back to the default one and write over it.
  if (const CLI::Option* empty = option_given_empty(app)) {
    std::cerr << tool << ": " << empty->get_name() << " is given an empty value (see --help)\n";
    return kExitBadUsage;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    body();
    if (interrupted.load()) {
      std::cerr << tool << ": interrupted\n";
      return kExitInterrupted;
    }
    if (!standard_output_written()) {
      std::cerr << tool
                << ": standard output: " << (errno != 0 ? std::strerror(errno) : "write error")
                << "; results lost\n";
      return kExitBadData;
    }
    return kExitOk;
  } catch (const UsageError& e) {
    std::cerr << tool << ": " << one_line(e.what()) << " (see --help)\n";
    return kExitBadUsage;
  } catch (const Cancelled&) {
    std::cerr << tool << ": interrupted; no output written\n";
    return kExitInterrupted;
  } catch (const std::bad_alloc&) {
    std::cerr << tool << ": out of memory\n";
    return kExitBadData;
  } catch (const std::exception& e) {
    std::cerr << tool << ": " << one_line(e.what()) << "\n";
    return kExitBadData;
  }
}

ProgressBar::ProgressBar(std::string label, bool quiet)
    : label_(std::move(label)),
      enabled_(!quiet && ::isatty(STDERR_FILENO)),
      start_(std::chrono::steady_clock::now()) {
  control_.cancel = &interrupted;
  if (!enabled_) return;
  control_.progress = [this](std::size_t done, std::size_t total) {
    const auto now = std::chrono::steady_clock::now();
    const long long ms =
        std::chrono::duration_cast<std::chrono::milliseconds>(now - start_).count();
    long long last = last_draw_ms_.load();
    if (done < total && ms - last < 100) return;  // at most ten redraws a second
    if (!last_draw_ms_.compare_exchange_strong(last, ms)) return;
    const int width = 30;
    const int filled = total ? int(width * double(done) / double(total)) : width;
    std::fprintf(stderr, "\r%s [%-*s] %3d%% %zu/%zu %.1f s", label_.c_str(), width,
                 std::string(std::size_t(filled), '#').c_str(),
                 total ? int(100 * done / total) : 100, done, total, ms / 1000.0);
    std::fflush(stderr);
  };
}

ProgressBar::~ProgressBar() {
  finish();
}

void ProgressBar::print_line(const std::string& line) const {
  std::fprintf(stderr, "%s%s\n", enabled_ ? "\r\033[K" : "", line.c_str());
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (!enabled_) return;
  enabled_ = false;
  control_.progress = nullptr;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
}

std::unique_ptr<tbb::task_arena> thread_arena(int threads) {
  // No more than the cores: oneTBB runs no more, and asking for more prints its own warning.
  if (threads > 0)
    return std::make_unique<tbb::task_arena>(std::min(threads, tbb::info::default_concurrency()));
  return std::make_unique<tbb::task_arena>();
}

Shard parse_shard_option(const std::string& text, std::uint64_t total, const std::string& what) {
  Shard shard;
  try {
    shard = parse_shard(text);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--shard: ") + e.what());
  }
  if (std::uint64_t(shard.count) > total)
    throw UsageError("--shard " + text + ": " + std::to_string(shard.count) + " shards of " +
                     std::to_string(total) + " " + what + " leave some empty; use at most " +
                     std::to_string(total));
  return shard;
}

namespace {

// A finite number, at least `lowest` (above it when `strictly`) and at most `highest`, named
// `what` in the message.
CLI::Validator number_check(double lowest, bool strictly, const std::string& what,
                            const std::string& description,
                            double highest = std::numeric_limits<double>::max()) {
  return CLI::Validator(
      [lowest, strictly, highest, what](std::string& text) -> std::string {
        double value = 0;
        if (!CLI::detail::lexical_cast(text, value) || !std::isfinite(value) || value < lowest ||
            (strictly && value == lowest) || value > highest)
          return what + " is required, got " + text;
        return {};
      },
      description, what);
}

}  // namespace

CLI::Validator finite_number() {
  return number_check(-std::numeric_limits<double>::max(), false, "a finite number", "FINITE");
}
CLI::Validator non_negative_number() {
  return number_check(0, false, "a finite number >= 0", "NONNEGATIVE");
}
CLI::Validator positive_number() {
  return number_check(0, true, "a finite number > 0", "POSITIVE");
}
CLI::Validator number_between(double lowest, double highest) {
  std::ostringstream what;
  what << "a number from " << lowest << " to " << highest;
  return number_check(lowest, false, what.str(), "NUMBER", highest);
}

CLI::Validator unsigned_number() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::uint64_t value = 0;
        const char* end = text.data() + text.size();
        const auto [stop, error] = std::from_chars(text.data(), end, value);
        if (text.empty() || error != std::errc() || stop != end)
          return "a whole number from 0 to 18446744073709551615 is required, got " + text;
        return {};
      },
      "UINT64", "a whole number from 0 to 2^64 - 1");
}

Vec3 parse_triple(const std::string& text, const std::string& option) {
  Vec3 v;
  std::istringstream in(text);
  char comma1 = 0, comma2 = 0;
  if (!(in >> v[0] >> comma1 >> v[1] >> comma2 >> v[2]) || comma1 != ',' || comma2 != ',' ||
      !(in >> std::ws).eof())
    throw UsageError(option + " expects three numbers X,Y,Z, got '" + text + "'");
  for (double x : v)
    if (!std::isfinite(x)) throw UsageError(option + " holds a non-finite number: '" + text + "'");
  return v;
}

namespace {

// Whether two paths name one file: the same file when both exist, else the same absolute path.
bool same_file(const std::string& x, const std::string& y) {
  std::error_code error;
  if (std::filesystem::exists(x, error) && std::filesystem::exists(y, error))
    return std::filesystem::equivalent(x, y, error) && !error;
  return std::filesystem::weakly_canonical(x, error) == std::filesystem::weakly_canonical(y, error);
}

}  // namespace

void check_outputs_spare_inputs(const std::vector<NamedPath>& outputs,
                                const std::vector<NamedPath>& given) {
  // What each input is, for the message, and where it lies. A manifest's shards, and their
  // checksums, are read too; JSON that is not a manifest (a spec, a scene) lists nothing, and
  // the tool's own reading reports a broken one.
  std::vector<std::pair<std::string, std::string>> inputs;
  for (const NamedPath& in : given) {
    if (in.path.empty()) continue;
    inputs.push_back({in.what.empty() ? "the file " + in.option + " reads" : in.what, in.path});
    // A shard's checksum beside it (capture2qt's) belongs to it.
    inputs.push_back({"the checksum of " + in.path, checksum_path(in.path)});
    if (!is_manifest(in.path)) continue;
    CaptureManifest manifest;
    try {
      manifest = read_manifest(in.path);
    } catch (const FileError&) {
      continue;
    }
    for (std::size_t k = 0; k < manifest.shards.size(); ++k) {
      inputs.push_back({"a shard " + in.path + " lists", manifest.shard_path(k)});
      inputs.push_back(
          {"the checksum of a shard " + in.path + " lists", checksum_path(manifest.shard_path(k))});
    }
  }
  for (std::size_t k = 0; k < outputs.size(); ++k) {
    const NamedPath& out = outputs[k];
    if (out.path.empty()) continue;
    for (const auto& [what, path] : inputs)
      if (same_file(out.path, path))
        throw UsageError(out.option + " " + out.path + " is " + what +
                         ": writing it would destroy the input");
    for (std::size_t j = 0; j < k; ++j)
      if (!outputs[j].path.empty() && same_file(out.path, outputs[j].path))
        throw UsageError(outputs[j].option + " and " + out.option + " name the same file, " +
                         out.path);
  }
}

void check_output_place(const std::string& path) {
  if (path.empty()) return;
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw FileError(path + ": is a folder; name the file to write");
  const std::filesystem::path folder = std::filesystem::absolute(path, error).parent_path();
  if (!std::filesystem::is_directory(folder, error)) throw FileError(path + ": no such folder");
}

std::string lower_case_extension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return extension;
}

void check_png_name(const std::string& path, const std::string& option) {
  if (!path.empty() && lower_case_extension(path) != ".png")
    throw UsageError(option + " names a PNG file (.png), got " + path);
}

Vec3 parse_direction(const std::string& text, const std::string& option) {
  const Vec3 unit = unit_direction(parse_triple(text, option));
  if (unit == Vec3::Zero()) throw UsageError(option + " must not be zero");
  return unit;
}

}  // namespace basis::cli
