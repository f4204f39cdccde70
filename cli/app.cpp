#include "rtsim_revision.h"
#include "commands.h"

#include <rtsim/workloads/host.h>
#include <rtsim/workloads/numbers.h>

#include <stdlib.h>

#include <cstdint>
#include <limits>
#include <string>

namespace rtsim::cli {

namespace {

// The strict reader's verdict on one command-line value of a CLI11 numeric type:
// "" when it may go on to CLI11's conversion, else why not.
std::string strict_number_problem(const std::string& type, const std::string& value) {
  if (type == "UINT") {
    uint64_t v = 0;
    const std::string problem = unsigned_syntax_problem(value);
    if (!problem.empty()) return problem;
    if (!parse_unsigned(value, 0, UINT64_MAX, v)) return "value " + value + " is past 2^64 - 1";
  } else if (type == "INT") {
    int64_t v = 0;
    const std::string problem = signed_syntax_problem(value);
    if (!problem.empty()) return problem;
    if (!parse_signed(value, INT64_MIN, INT64_MAX, v)) return "value " + value + " is past the 64-bit range";
  } else if (type == "FLOAT") {
    double v = 0;
    const std::string problem = real_syntax_problem(value);
    if (!problem.empty()) return problem;
    if (!parse_real(value, -std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), v))
      return "value " + value + " is not a finite number";
  }
  return "";
}

}  // namespace

namespace {
// CLI11's type of the option's values: get_type_name() without the descriptions its
// checks append ("INT:INT in [1 - 1024]" for -j with CLI::Range).
std::string value_type(const CLI::Option& option) {
  const std::string type = option.get_type_name();
  return type.substr(0, type.find(':'));
}
}  // namespace

bool is_numeric_option(const CLI::Option& option) {
  const std::string type = value_type(option);
  return option.get_expected_max() > 0 && (type == "UINT" || type == "INT" || type == "FLOAT");
}

// CLI11 reads numbers with strtoull/strtoll(base 0) and strtod: "010" is octal,
// "0x10" hex, "-5" wraps to 2^64 - 5 in an unsigned, 2^64 saturates and "" is 0.
// This check, put in front of every numeric option's own checks, lets only what
// rtsim's strict reader (rtsim/workloads/numbers.h) accepts through; the option's
// range check and CLI11's conversion (which refuses a value too large for a
// narrower type) follow.
void make_numbers_strict(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (!is_numeric_option(*option)) continue;
    const std::string type = value_type(*option);
    option->transform(CLI::Validator(
        [type](std::string& value) { return strict_number_problem(type, value); }, "", "strict-number"));
  }
  for (CLI::App* sub : app.get_subcommands({})) make_numbers_strict(*sub);
}

void add_rtsim_commands(CLI::App& app) {
  app.require_subcommand(1);
  app.set_version_flag("--version", RTSIM_VERSION " (" RTSIM_GIT_REVISION ")");
  // Before the subcommand: rtsim --memory-limit 64G campaign run ... The variable is
  // what every rtsim process reads, so the jobs a campaign starts get the limit too.
  app.add_option_function<std::string>(
         "--memory-limit",
         [](const std::string& size) {
           parse_memory_size(size, "--memory-limit");
           ::setenv(kMemoryLimitVariable, size.c_str(), 1);
         },
         std::string("most memory one rtsim may plan to use, e.g. 64G (default: half the\n"
                     "machine's memory); sets ") + kMemoryLimitVariable + " for it and its jobs")
      ->type_name("SIZE");
  add_scenes_command(app);
  add_build_command(app);
  add_campaign_command(app);
  add_report_command(app);
  add_trace_command(app);
  add_simulate_command(app);
  add_table1_command(app);
  add_accuracy_command(app);
  add_claim_command(app);
  add_stats_command(app);
  add_dram_replay_command(app);
  make_numbers_strict(app);
}

}  // namespace rtsim::cli
