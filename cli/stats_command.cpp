// rtsim stats-reference: docs/stats.md, every statistic with its unit, the levels
// that write it and its description, from runs at every fidelity level (the model's
// own descriptions), with the accounting identities (reports/stats_reference.h).
#include "cli_util.h"
#include "commands.h"

#include <rtsim/reports/child_process.h>
#include <rtsim/reports/stats_reference.h>
#include <rtsim/workloads/files.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <unistd.h>

namespace rtsim::cli {

void add_stats_command(CLI::App& root) {
  auto out = std::make_shared<std::string>();
  CLI::App* cmd = root.add_subcommand(
      "stats-reference", "Every statistic simulate writes, with unit and description (docs/stats.md)");
  cmd->add_option("--out", *out, "write the Markdown here (default: print it)");
  cmd->callback([out] {
    if (!out->empty()) check_output_file(*out, "--out");
    const std::filesystem::path work =
        std::filesystem::temp_directory_path() / ("rtsim-stats-reference-" + std::to_string(::getpid()));
    std::string markdown;
    try {
      markdown = make_stats_reference(self_executable(), work);
    } catch (...) {
      std::error_code ec;
      std::filesystem::remove_all(work, ec);
      throw;
    }
    std::error_code ec;
    std::filesystem::remove_all(work, ec);
    if (out->empty()) std::cout << markdown;
    else write_file_atomic(*out, markdown);
  });
}

}  // namespace rtsim::cli
