#pragma once
// Runs the rtsim executable the way a user does and captures what it printed.
#include <array>
#include <cstdio>
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
