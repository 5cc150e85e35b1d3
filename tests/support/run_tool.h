// Runs the project's command-line tools from tests: the executables next to the test binary,
// with stdout and stderr captured and the exit status returned.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

extern char** environ;

namespace basis::testing {

struct ToolResult {
  int status = -1;  // exit status, or 128 + signal
  std::string out;
  std::string err;
};

inline std::filesystem::path tool_directory() {
  return std::filesystem::read_symlink("/proc/self/exe").parent_path();
}

inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The number of threads of a running process (Linux); 0 once it has exited (a zombie) or is gone.
inline int thread_count(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("State:", 0) == 0 && line.find('Z') != std::string::npos) return 0;
    if (line.rfind("Threads:", 0) == 0) return std::stoi(line.substr(8));
  }
  return 0;
}

// Runs a tool; when interrupt_after_ms >= 0, sends it `signal_number` (SIGINT by default) that
// many milliseconds after it starts its first worker thread (by then its signal handlers are in
// place and it is at work, however slowly it started, as under the sanitizers), or after 60 s.
inline ToolResult run_tool(const std::string& tool, const std::vector<std::string>& args,
                           const std::string& working_directory = "", int interrupt_after_ms = -1,
                           int signal_number = SIGINT) {
  const std::filesystem::path exe = tool_directory() / tool;
  const std::filesystem::path capture =
      std::filesystem::temp_directory_path() / ("basis_tool_" + std::to_string(::getpid()));
  const std::string out_path = capture.string() + ".out", err_path = capture.string() + ".err";
  std::vector<std::string> argv_storage = {exe.string()};
  argv_storage.insert(argv_storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_storage)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out_path.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err_path.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (!working_directory.empty())
    posix_spawn_file_actions_addchdir_np(&actions, working_directory.c_str());
  pid_t pid = 0;
  ToolResult result;
  if (posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv.data(), environ) == 0) {
    int status = 0;
    if (interrupt_after_ms >= 0) {
      // A tool that exits early is not waited for (its count drops to 0).
      for (int waited = 0; waited < 60000 && thread_count(pid) == 1; waited += 5)
        ::usleep(5000);
      ::usleep(useconds_t(interrupt_after_ms) * 1000);
      ::kill(pid, signal_number);
    }
    ::waitpid(pid, &status, 0);
    result.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  posix_spawn_file_actions_destroy(&actions);
  result.out = slurp(out_path);
  result.err = slurp(err_path);
  std::filesystem::remove(out_path);
  std::filesystem::remove(err_path);
  return result;
}

// Number of lines of a tool's stderr (a final newline does not start a line).
inline int line_count(const std::string& text) {
  int lines = 0;
  for (std::size_t i = 0; i < text.size(); ++i)
    if (text[i] == '\n' || i + 1 == text.size()) ++lines;
  return lines;
}

}  // namespace basis::testing
