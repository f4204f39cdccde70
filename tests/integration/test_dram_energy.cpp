// Issue 37: the DRAM's background (standby) energy, dram.background_mw over every
// channel for the simulated time, reported beside the dynamic energy, not in it.
#include "integration/cli_runner.h"

#include <rtsim/reports/child_process.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace {

namespace fs = std::filesystem;

nlohmann::json simulate(const fs::path& dir, const std::string& toml) {
  std::ofstream(dir / "c.toml") << toml;
  const CliResult r = run_rtsim_command("cd " + rtsim::shell_quote(dir.string()) +
                                        " && RTSIM_NO_PROGRESS=1 timeout 300 " +
                                        rtsim::shell_quote(RTSIM_BINARY) +
                                        " simulate --fidelity cycle --res 24x24 --config c.toml --out-dir o 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "o" / "stats.json");
  return nlohmann::json::parse(in);
}

double value(const nlohmann::json& s, const std::string& a, const std::string& b) {
  return s.at(a).at(b).at("value").get<double>();
}

TEST(DramEnergy, BackgroundIsStandbyPowerOverEveryChannelForTheRun) {
  const fs::path dir = fs::temp_directory_path() / ("rtsim_dram_energy_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const nlohmann::json s = simulate(dir, "preset = \"desktop-gpu\"\n");
  const double seconds = value(s, "time", "seconds");
  const double background = s.at("energy").at("dram_background").at("pj").at("value").get<double>();
  // desktop-gpu: 12 GDDR6 channels of 81 mW each.
  EXPECT_NEAR(background, 12 * 81e-3 * seconds * 1e12, 1e-6 * background);
  EXPECT_GT(background, 0);
  const double rays = value(s, "rays", "total");
  EXPECT_NEAR(value(s, "energy", "pj_per_ray_with_background") - value(s, "energy", "pj_per_ray"),
              background / rays, 1e-6 * background / rays);
  // Twice the standby power: twice the background energy for the time that run took.
  const nlohmann::json t = simulate(dir, "preset = \"desktop-gpu\"\n[dram]\nbackground_mw = 162\n");
  EXPECT_NEAR(t.at("energy").at("dram_background").at("pj").at("value").get<double>(),
              12 * 162e-3 * value(t, "time", "seconds") * 1e12, 1e-6 * background * 2);
  fs::remove_all(dir);
}

}  // namespace
