#pragma once
// The rtsim command line is a thin layer over the libraries: one file per
// subcommand, each adding itself to the root app here.
#include <CLI/CLI.hpp>

#include <stdexcept>

namespace rtsim::cli {

// Thrown by a subcommand that finished but must report a non-zero exit status
// (e.g. --validate found disagreements). Bad input throws rtsim::InputError (exit 2).
struct ExitStatus : std::runtime_error {
  int code;
  ExitStatus(int c, const std::string& message) : std::runtime_error(message), code(c) {}
};

void add_scenes_command(CLI::App& root);
void add_build_command(CLI::App& root);
void add_trace_command(CLI::App& root);
void add_simulate_command(CLI::App& root);
void add_campaign_command(CLI::App& root);
void add_table1_command(CLI::App& root);
void add_accuracy_command(CLI::App& root);
void add_report_command(CLI::App& root);
void add_claim_command(CLI::App& root);
void add_stats_command(CLI::App& root);
void add_dram_replay_command(CLI::App& root);

// The whole command line: every subcommand above, then make_numbers_strict.
void add_rtsim_commands(CLI::App& app);
// Puts the strict number reader in front of every numeric option of `app` and its
// subcommands (an option is numeric when CLI11 types it UINT, INT or FLOAT).
void make_numbers_strict(CLI::App& app);
bool is_numeric_option(const CLI::Option& option);

}  // namespace rtsim::cli
