#pragma once
// Runs the rtsim executable the way a user does and captures what it printed.
#include <rtsim/reports/child_process.h>

#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>
#include <sys/wait.h>

struct CliResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs a shell command line as it is (redirections included) and captures its stdout.
inline CliResult run_rtsim_command(const std::string& command) {
  CliResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

inline CliResult run_rtsim(const std::string& args) {
  return run_rtsim_command(std::string(RTSIM_BINARY) + " " + args + " 2>&1");
}

// rtsim run in folder `cwd` without progress bars, stopped after 300 s.
inline CliResult run_rtsim_in(const std::filesystem::path& cwd, const std::string& args) {
  return run_rtsim_command("cd " + rtsim::shell_quote(cwd.string()) + " && RTSIM_NO_PROGRESS=1 timeout 300 " +
                           rtsim::shell_quote(RTSIM_BINARY) + " " + args + " 2>&1");
}

// An empty folder of the test's own: <tmp>/<prefix>_<name>_<pid>.
inline std::filesystem::path fresh_test_folder(const std::string& prefix, const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / (prefix + "_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}
