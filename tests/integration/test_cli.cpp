// The command line keeps its promises: --help everywhere, bad input -> exit 2 with
// a message naming the cause, results written atomically.
#include "cli_runner.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

TEST(Cli, HelpWorksForEverySubcommand) {
  const CliResult root = run_rtsim("--help");
  ASSERT_EQ(root.exit_code, 0) << root.output;
  // Every subcommand listed in the root help answers --help itself.
  const std::string subcommands[] = {"scenes", "build", "trace", "simulate", "campaign",
                                     "table1", "accuracy", "report"};
  for (const std::string& sub : subcommands) {
    if (root.output.find("\n  " + sub) == std::string::npos) continue;  // not built yet
    const CliResult r = run_rtsim(sub + " --help");
    EXPECT_EQ(r.exit_code, 0) << sub << ": " << r.output;
    EXPECT_NE(r.output.find("Usage"), std::string::npos) << sub;
  }
  EXPECT_EQ(run_rtsim("scenes info --help").exit_code, 0);
  EXPECT_EQ(run_rtsim("scenes render --help").exit_code, 0);
}

// The subcommands a help text lists under "Subcommands:" (two-space indented names).
std::vector<std::string> listed_subcommands(const std::string& help) {
  std::vector<std::string> out;
  const size_t at = help.find("Subcommands:");
  if (at == std::string::npos) return out;
  std::istringstream lines(help.substr(at));
  std::string line;
  std::getline(lines, line);
  while (std::getline(lines, line) && line.rfind("  ", 0) == 0) {
    const std::string name = line.substr(2, line.find(' ', 2) - 2);
    if (!name.empty() && name[0] != ' ') out.push_back(name);
  }
  return out;
}

// Every help text, the root's and each subcommand's at every depth, fits a
// 120-column terminal.
TEST(Cli, EveryHelpTextFits120Columns) {
  std::vector<std::string> commands = {""};
  for (size_t i = 0; i < commands.size(); ++i) {
    const CliResult r = run_rtsim(commands[i] + " --help");
    ASSERT_EQ(r.exit_code, 0) << commands[i] << ": " << r.output;
    std::istringstream lines(r.output);
    std::string line;
    while (std::getline(lines, line))
      EXPECT_LE(line.size(), 120u) << "rtsim " << commands[i] << " --help: " << line;
    for (const std::string& sub : listed_subcommands(r.output))
      commands.push_back(commands[i].empty() ? sub : commands[i] + " " + sub);
  }
  EXPECT_GT(commands.size(), 15u);  // the root, its subcommands and theirs
}

TEST(Cli, UnknownSceneExitsTwoAndNamesIt) {
  const CliResult r = run_rtsim("scenes info no-such-scene");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no-such-scene"), std::string::npos) << r.output;
}

// A path the file system cannot even look up (a component longer than NAME_MAX)
// is an unknown scene, exit 2, not an internal error.
TEST(Cli, SceneNameTooLongForTheFileSystemExitsTwoAndNamesIt) {
  const std::string name = "scenes/" + std::string(300, 'x') + ".toml";
  const CliResult r = run_rtsim("scenes info " + name);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(name), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
}

// The same for a campaign's preset file (found by fuzz_campaign: the file-system
// error escaped as "internal error", exit 1).
TEST(Cli, CampaignPresetNameTooLongForTheFileSystemExitsTwoAndNamesIt) {
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("rtsim-long-preset-" + std::to_string(::getpid()) + ".toml");
  std::ofstream(file) << "[campaign]\nname = \"c\"\n[sweep]\nscene = \"cornell\"\n"
                      << "builder = [\"sah\"]\npreset = [\"" << std::string(300, 'q') << ".toml\"]\n";
  const CliResult r = run_rtsim("campaign list " + file.string());
  std::filesystem::remove(file);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("preset"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
}

TEST(Cli, BadOptionExitsTwo) {
  EXPECT_EQ(run_rtsim("scenes info --no-such-flag").exit_code, 2);
  EXPECT_EQ(run_rtsim("no-such-command").exit_code, 2);
  EXPECT_EQ(run_rtsim("scenes render cornell --width 0").exit_code, 2);
}

TEST(Cli, ScenesInfoJsonReportsTheValidation) {
  const CliResult r = run_rtsim("scenes info cornell --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"degenerate_kept\""), std::string::npos);
  EXPECT_NE(r.output.find("\"view2\""), std::string::npos);
}

TEST(Cli, BadDescriptorKeyIsNamed) {
  const auto dir = std::filesystem::temp_directory_path() / "rtsim_cli_descriptor";
  std::filesystem::create_directories(dir);
  {
    std::ofstream obj(dir / "tri.obj");
    obj << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::ofstream toml(dir / "scene.toml");
    toml << "name = \"t\"\n[[mesh]]\nfile = \"tri.obj\"\n[ao]\ncutof = 0.1\n";
  }
  const CliResult r = run_rtsim("scenes info " + (dir / "scene.toml").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("ao.cutof"), std::string::npos) << r.output;
  std::filesystem::remove_all(dir);
}

TEST(Cli, RenderWritesAPngAtomically) {
  const auto dir = std::filesystem::temp_directory_path() / "rtsim_cli_render";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto png = dir / "c.png";
  const CliResult r = run_rtsim("scenes render cornell --width 64 --height 48 -o " + png.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(std::filesystem::exists(png));
  std::ifstream in(png, std::ios::binary);
  char magic[8];
  in.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  // Nothing but the picture is left behind (no temporary file).
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
  std::filesystem::remove_all(dir);
}
