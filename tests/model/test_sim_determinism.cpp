// rtsim simulate: the same inputs give a byte-identical stats.json; host-time
// figures live in host.json for exactly that reason. Also checks the files the
// command writes and that bad input is refused with exit code 2.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace {

std::string read(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int run(const std::string& args) {
  const std::string cmd = std::string(RTSIM_BINARY) + " simulate " + args + " > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::filesystem::path temp_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() /
             ("rtsim_sim_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

void same_twice(const std::string& fidelity) {
  const auto a = temp_dir(fidelity + "_a"), b = temp_dir(fidelity + "_b");
  const std::string common =
      "--scene cornell --fidelity " + fidelity + " --res 24x24 --ao 2 --config mobile --out-dir ";
  ASSERT_EQ(run(common + a.string()), 0);
  ASSERT_EQ(run(common + b.string()), 0);
  const std::string sa = read(a / "stats.json"), sb = read(b / "stats.json");
  ASSERT_FALSE(sa.empty());
  EXPECT_EQ(sa, sb);
  const auto config = nlohmann::json::parse(read(a / "config.json"));
  EXPECT_EQ(config["fidelity"], fidelity);
  EXPECT_TRUE(config.contains("git_revision"));
  EXPECT_TRUE(config["inputs"].contains("scene_hash"));
  EXPECT_EQ(config["hardware"]["trv"]["units"], 4);
  const auto host = nlohmann::json::parse(read(a / "host.json"));
  EXPECT_GT(host["host_seconds"]["value"].get<double>(), 0.0);
  EXPECT_EQ(sa.find("host"), std::string::npos);
  std::filesystem::remove_all(a);
  std::filesystem::remove_all(b);
}

}  // namespace

TEST(SimDeterminism, CycleStatsAreByteIdentical) { same_twice("cycle"); }
TEST(SimDeterminism, LtStatsAreByteIdentical) { same_twice("lt"); }
TEST(SimDeterminism, FunctionalStatsAreByteIdentical) { same_twice("functional"); }

TEST(SimDeterminism, BadInputExitsWithTwo) {
  const auto dir = temp_dir("bad");
  EXPECT_EQ(run("--scene cornell --fidelity fast --out-dir " + dir.string()), 2);
  EXPECT_EQ(run("--scene cornell --config /nonexistent.toml --out-dir " + dir.string()), 2);
  const auto toml = dir.string() + ".toml";
  std::ofstream(toml) << "[trv]\nunits = 0\n";
  EXPECT_EQ(run("--scene cornell --config " + toml + " --out-dir " + dir.string()), 2);
  std::filesystem::remove(toml);
  std::filesystem::remove_all(dir);
}

TEST(SimDeterminism, RayFileReplayRunsWithoutShading) {
  const auto dir = temp_dir("replay");
  std::filesystem::create_directories(dir);
  const std::string rays = (dir / "rays.bin").string();
  const std::string trace = std::string(RTSIM_BINARY) + " trace --scene cornell --res 16x16 --ao 0 --rays-out " +
                            rays + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(trace.c_str()), 0);
  ASSERT_EQ(run("--scene cornell --fidelity cycle --rays-in " + rays + " --out-dir " + (dir / "out").string()), 0);
  const auto stats = nlohmann::json::parse(read(dir / "out" / "stats.json"));
  EXPECT_FALSE(stats.contains("shading"));
  EXPECT_GT(stats["rays"]["total"]["value"].get<double>(), 0.0);
  const auto config = nlohmann::json::parse(read(dir / "out" / "config.json"));
  EXPECT_FALSE(config["inputs"]["rays_hash"].get<std::string>().empty());
  std::filesystem::remove_all(dir);
}
