// Issue 36: every number on the command line is read by the one strict reader
// (rtsim/workloads/numbers.h). The options are found by walking CLI11's option
// list of the real command line (rtsim_cli), not listed by hand, so a flag added
// tomorrow is walked too.
#include "integration/cli_runner.h"

#include "commands.h"

#include <rtsim/workloads/numbers.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

namespace {

struct NumericFlag {
  std::vector<std::string> command;  // e.g. {"campaign", "run"}
  std::vector<std::string> required;  // what the subcommand needs besides the flag
  std::string flag;                   // the long name, else the short one
  std::string type;                   // CLI11's UINT, INT or FLOAT
};

std::string flag_name(const CLI::Option& o) {
  if (!o.get_lnames().empty()) return "--" + o.get_lnames().front();
  return "-" + o.get_snames().front();
}

// Required positionals and options get a placeholder, so that the parse reaches
// the numbers (a missing FILE is reported after them, but it must not be missing).
std::vector<std::string> placeholders(const CLI::App& app) {
  std::vector<std::string> words;
  for (const CLI::Option* o : app.get_options()) {
    if (!o->get_required()) continue;
    if (o->get_positional()) words.push_back("placeholder.toml");
    else if (o->get_expected_max() == 0) words.push_back(flag_name(*o));
    else words.insert(words.end(), {flag_name(*o), "placeholder"});
  }
  return words;
}

void walk(const CLI::App& app, std::vector<std::string> command, std::vector<NumericFlag>& out) {
  for (const CLI::Option* o : app.get_options()) {
    // Without what checks append to it ("INT:INT in [1 - 1024]").
    const std::string type = o->get_type_name().substr(0, o->get_type_name().find(':'));
    if (o->get_positional() || o->get_expected_max() == 0) continue;
    if (type == "UINT" || type == "INT" || type == "FLOAT") out.push_back({command, placeholders(app), flag_name(*o), type});
  }
  for (const CLI::App* sub : app.get_subcommands({})) {
    std::vector<std::string> deeper = command;
    deeper.push_back(sub->get_name());
    walk(*sub, deeper, out);
  }
}

std::vector<NumericFlag> every_numeric_flag() {
  CLI::App app;
  rtsim::cli::add_rtsim_commands(app);
  std::vector<NumericFlag> flags;
  walk(app, {}, flags);
  return flags;
}

// Parses `words` with a fresh command line (a parse consumes it); the message of the
// CLI11 error it throws, or "" if it parsed (and ran: the values here never should).
std::string parse_error(const std::vector<std::string>& words) {
  CLI::App app;
  rtsim::cli::add_rtsim_commands(app);
  std::vector<std::string> reversed(words.rbegin(), words.rend());
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("not a parse error: ") + e.what();
  }
  return "";
}

// The walk finds the flags the issue names; a walk that found nothing would pass.
TEST(StrictNumbers, TheWalkFindsEveryKindOfNumericFlag) {
  const std::vector<NumericFlag> flags = every_numeric_flag();
  std::set<std::string> names;
  std::set<std::string> types;
  for (const NumericFlag& f : flags) {
    std::string name;
    for (const std::string& c : f.command) name += c + " ";
    names.insert(name + f.flag);
    types.insert(f.type);
  }
  for (const char* expected : {"simulate --frames", "simulate --seed", "trace --spp", "trace --ao",
                               "build --max-leaf-size", "campaign run --jobs", "trace --shuffle-faces",
                               "build --build-seed", "trace --heat-max", "claim --replicates"})
    EXPECT_EQ(names.count(expected), 1u) << expected;
  EXPECT_EQ(types, (std::set<std::string>{"FLOAT", "INT", "UINT"}));
  EXPECT_GT(flags.size(), 40u);
}

// Every numeric flag of every subcommand refuses octal, hex, a '+', the empty
// string and 2^64 (and a '-' where it is unsigned), with a message naming the flag
// and the value, before any work: a parse error, never a run.
TEST(StrictNumbers, EveryNumericFlagRefusesWhatIsNotADecimalNumber) {
  size_t cases = 0;
  for (const NumericFlag& f : every_numeric_flag()) {
    std::vector<std::string> bad = {"010", "0x10", "+2", ""};
    if (f.type != "FLOAT") bad.push_back("18446744073709551616");
    if (f.type == "UINT") bad.push_back("-1");
    if (f.type == "FLOAT") bad.insert(bad.end(), {"nan", "inf", "1e999", "0x1p4"});
    for (const std::string& value : bad) {
      std::vector<std::string> words = f.command;
      words.insert(words.end(), f.required.begin(), f.required.end());
      words.insert(words.end(), {f.flag, value});
      const std::string error = parse_error(words);
      std::string shown;
      for (const std::string& w : words) shown += w + " ";
      EXPECT_NE(error.find(f.flag), std::string::npos) << shown << "-> " << error;
      EXPECT_TRUE(error.find("'" + value + "'") != std::string::npos ||
                  error.find("value " + value + " ") != std::string::npos || (value.empty() && error.find("nothing") != std::string::npos))
          << shown << "-> " << error;
      ++cases;
    }
  }
  EXPECT_GT(cases, 200u);
  std::printf("walked %zu numeric flags, %zu refusals checked\n", every_numeric_flag().size(), cases);
}

// The binary itself: exit 2 and the flag named (main maps CLI11's errors to 2),
// for the issue's own examples.
TEST(StrictNumbers, TheIssuesExamplesExitTwo) {
  for (const char* args : {"simulate --frames 010 --out-dir x", "simulate --frames 0x10 --out-dir x",
                           "simulate --frames +2 --out-dir x", "simulate --frames ' 2' --out-dir x",
                           "trace --seed -5", "trace --seed 18446744073709551616", "trace --seed ''",
                           "trace --shuffle-faces -1", "build --build-seed -1", "campaign run x.toml -j 010"}) {
    const CliResult r = run_rtsim(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    const std::string flag = std::string(args).substr(std::string(args).find("--") != std::string::npos &&
                                                              std::string(args).find(" -j") == std::string::npos
                                                          ? std::string(args).find("--")
                                                          : std::string(args).find("-j"));
    EXPECT_NE(r.output.find(flag.substr(0, flag.find(' '))), std::string::npos) << args << "\n" << r.output;
  }
}

// What the reader takes and what it gives: the same digits, and its limits.
TEST(StrictNumbers, TheReaderTakesDecimalNumbersAndKeepsEveryDigit) {
  uint64_t u = 0;
  EXPECT_TRUE(rtsim::parse_unsigned("18446744073709551615", 0, UINT64_MAX, u));
  EXPECT_EQ(u, UINT64_MAX);
  EXPECT_TRUE(rtsim::parse_unsigned("0", 0, 10, u));
  EXPECT_EQ(u, 0u);
  int64_t i = 0;
  EXPECT_TRUE(rtsim::parse_signed("-9223372036854775808", INT64_MIN, INT64_MAX, i));
  EXPECT_EQ(i, INT64_MIN);
  EXPECT_FALSE(rtsim::parse_signed("-0x1", INT64_MIN, INT64_MAX, i));
  EXPECT_FALSE(rtsim::parse_signed("-", INT64_MIN, INT64_MAX, i));
  double d = 0;
  for (const char* good : {"0", "0.5", "-2", "1e-3", "2E+2", "123.456e1"}) EXPECT_TRUE(rtsim::parse_real(good, -1e9, 1e9, d)) << good;
  EXPECT_TRUE(rtsim::parse_real("1e-3", 0, 1, d));
  EXPECT_EQ(d, 1e-3);
  for (const char* bad : {".5", "5.", "1e", "01.5", "+1", "- 1", "1 ", "NaN", "Infinity", "0x10", "1,5"})
    EXPECT_FALSE(rtsim::parse_real(bad, -1e9, 1e9, d)) << bad;
}

}  // namespace
