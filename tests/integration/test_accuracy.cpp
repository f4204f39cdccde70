// rtsim accuracy --quick on cornell: the report exists, is written whole, and its
// numbers keep the properties the measurements promise (the reference against
// itself is exact, the fidelity levels count alike, more samples mean less error).
#include "cli_runner.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace {

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

TEST(Accuracy, QuickRunOnCornellWritesASaneReport) {
  const auto dir = std::filesystem::temp_directory_path() / "rtsim_accuracy_quick";
  std::filesystem::remove_all(dir);
  const CliResult r = run_rtsim("accuracy --quick --scene cornell --out-dir " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("Recommended settings"), std::string::npos) << r.output;

  // Every output is there, whole, and no temporary file was left behind.
  for (const char* name :
       {"accuracy.md", "accuracy.json", "accuracy.csv", "accuracy_tradeoffs.png", "accuracy_ao_images.png"})
    ASSERT_TRUE(std::filesystem::is_regular_file(dir / name)) << name;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
  EXPECT_EQ(read_text(dir / "accuracy_tradeoffs.png").substr(1, 3), "PNG");
  const std::string md = read_text(dir / "accuracy.md");
  EXPECT_NE(md.find("## Recommended settings"), std::string::npos);
  EXPECT_NE(md.find("accuracy_tradeoffs.png"), std::string::npos);

  const nlohmann::json j = nlohmann::json::parse(read_text(dir / "accuracy.json"));
  EXPECT_EQ(j["scene"], "cornell");
  EXPECT_TRUE(j["quick"].get<bool>());

  // 1. Fidelity: cycle against itself is exact; functional and lt share the memory
  // model (same DRAM bytes); all three count the same operations.
  std::map<std::string, nlohmann::json> level;
  for (const auto& p : j["fidelity"]) level[p["level"]] = p;
  ASSERT_EQ(level.size(), 3u);
  EXPECT_EQ(level["cycle"]["cycle_error"].get<double>(), 0.0);
  EXPECT_EQ(level["cycle"]["dram_error"].get<double>(), 0.0);
  EXPECT_GT(level["cycle"]["cycles"].get<double>(), 0.0);
  EXPECT_EQ(level["functional"]["dram_bytes"].get<double>(), level["lt"]["dram_bytes"].get<double>());
  for (const auto& [name, p] : level) {
    EXPECT_TRUE(p["counts_match_cycle"].get<bool>()) << name;
    EXPECT_GT(p["rays"].get<uint64_t>(), 0u) << name;
    EXPECT_GT(p["rays_per_host_second"].get<double>(), 0.0) << name;
    EXPECT_DOUBLE_EQ(p["ops_per_ray"].get<double>(), level["cycle"]["ops_per_ray"].get<double>()) << name;
  }

  // 2. Builder knobs: the occlusion values converge on the K = 256 values.
  std::map<int, double> occlusion_rmse, shared_rmse;
  std::set<std::string> families;
  for (const auto& k : j["knobs"]) {
    families.insert(k["family"].get<std::string>());
    if (k["reference"].get<bool>()) EXPECT_EQ(k["ops_error"].get<double>(), 0.0) << k["setting"];
    EXPECT_GT(k["ops_per_ray"].get<double>(), 0.0) << k["setting"];
    if (k["family"] == "ao_rays") occlusion_rmse[int(k["value"].get<double>())] = k["occlusion_rmse"];
    if (k["family"] == "ao_share") shared_rmse[int(k["value"].get<double>())] = k["occlusion_rmse"];
    if (k["family"] == "sbvh_alpha") EXPECT_GE(k["references"].get<uint64_t>(), j["triangles"].get<uint64_t>());
  }
  EXPECT_EQ(families, (std::set<std::string>{"ao_rays", "ao_share", "sah_bins", "sbvh_alpha"}));
  ASSERT_EQ(occlusion_rmse.size(), 5u);
  EXPECT_EQ(occlusion_rmse[256], 0.0);
  EXPECT_GT(occlusion_rmse[1], occlusion_rmse[16]);
  EXPECT_GT(occlusion_rmse[16], occlusion_rmse[64]);
  EXPECT_GT(occlusion_rmse[64], 0.0);
  // Shared estimates (quick: G = 1 and 16 at the default K = 4): G = 1 is the K = 4
  // per-triangle estimate; Cornell's triangles are each far wider than the sharing
  // cell, so none is pooled with another and G = 16 changes nothing.
  ASSERT_EQ(shared_rmse.size(), 2u);
  EXPECT_EQ(shared_rmse[1], occlusion_rmse[4]);
  EXPECT_EQ(shared_rmse[16], shared_rmse[1]);

  // 3. AO rays per pixel: the image error falls with the ray count, time does not.
  const auto& ao = j["ao_rays_per_pixel"];
  ASSERT_GE(ao.size(), 3u);
  EXPECT_TRUE(ao.back()["reference"].get<bool>());
  EXPECT_EQ(ao.back()["image_rmse"].get<double>(), 0.0);
  for (size_t i = 1; i + 1 < ao.size(); ++i) {
    EXPECT_LT(ao[i]["image_rmse"].get<double>(), ao[i - 1]["image_rmse"].get<double>()) << i;
    EXPECT_GT(ao[i]["rays"].get<uint64_t>(), ao[i - 1]["rays"].get<uint64_t>()) << i;
  }

  // 4. Resolution: every (resolution, seed) measured; the answer is one of them.
  const auto& res = j["resolution"];
  std::set<uint32_t> resolutions;
  double highest_mean = 0;
  for (const auto& p : res["points"]) resolutions.insert(p["resolution"].get<uint32_t>());
  EXPECT_EQ(res["points"].size(), resolutions.size() * 2);  // two seeds in --quick
  EXPECT_TRUE(resolutions.count(res["resolution_needed"].get<uint32_t>()));
  EXPECT_GT(res["rays_needed"].get<uint64_t>(), 0u);
  for (const auto& p : res["points"])
    if (p["resolution"].get<uint32_t>() == *resolutions.rbegin()) highest_mean += p["ops_per_ray"].get<double>() / 2;
  EXPECT_NEAR(res["reference_ops_per_ray"].get<double>(), highest_mean, 1e-9 * highest_mean);

  // 5. Memory traffic: every (resolution, level) run with every frame; cycle runs
  // only up to their resolution; frame 1 (cold) reads at least what the last does.
  const auto& traffic = j["traffic"];
  size_t traffic_rows = 0;
  ASSERT_FALSE(traffic["points"].empty());
  for (const auto& p : traffic["points"]) {
    const auto& d = p["dram_bytes_per_ray"];
    ASSERT_EQ(d.size(), 2u);  // --quick: two frames
    EXPECT_GE(d.front().get<double>(), d.back().get<double>());
    traffic_rows += d.size() + p["cycles_per_ray"].size();
    if (p["level"] == "cycle") EXPECT_EQ(p["cycles_per_ray"].size(), 2u);
  }
  ASSERT_EQ(traffic["verdicts"].size(), 1u);
  EXPECT_GE(traffic["verdicts"][0]["frames_needed"].get<uint32_t>(), 1u);
  EXPECT_TRUE(std::filesystem::exists(dir / "accuracy_traffic.png"));

  // Recommendations: one per topic, each with a setting and a reason.
  ASSERT_GE(j["recommendations"].size(), 6u);
  for (const auto& rec : j["recommendations"]) {
    EXPECT_FALSE(rec["setting"].get<std::string>().empty()) << rec["topic"];
    EXPECT_GT(rec["why"].get<std::string>().size(), 20u) << rec["topic"];
  }

  // The CSV has one row per measured point (fidelity: two error metrics each).
  const std::string csv = read_text(dir / "accuracy.csv");
  EXPECT_EQ(csv.rfind("scene,section,setting", 0), 0u);
  size_t lines = 0;
  for (char c : csv) lines += c == '\n';
  size_t occlusion_rows = occlusion_rmse.size() + shared_rmse.size();
  EXPECT_EQ(lines, 1 + 2 * j["fidelity"].size() + j["knobs"].size() + occlusion_rows + ao.size() +
                       res["points"].size() + traffic_rows);
  std::filesystem::remove_all(dir);
}

TEST(Accuracy, BadSceneCameraOrHardwareExitsTwoAndNamesIt) {
  const auto dir = std::filesystem::temp_directory_path() / "rtsim_accuracy_bad";
  CliResult r = run_rtsim("accuracy --quick --scene no-such-scene --out-dir " + dir.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no-such-scene"), std::string::npos) << r.output;
  r = run_rtsim("accuracy --quick --scene cornell --camera no-such-camera --out-dir " + dir.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no-such-camera"), std::string::npos) << r.output;
  r = run_rtsim("accuracy --quick --scene cornell --config no-such-preset --out-dir " + dir.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no-such-preset"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "accuracy.json"));
  std::filesystem::remove_all(dir);
}

// The fidelity levels are compared on every scene asked for, each against its own
// cycle-level run, and the recommendation names the scenes it comes from and every
// scene where a faster level leaves the tolerance.
TEST(Accuracy, FidelityOverSeveralScenesSaysWhereALevelFails) {
  const auto dir = std::filesystem::temp_directory_path() / "rtsim_accuracy_scenes";
  std::filesystem::remove_all(dir);
  const CliResult r =
      run_rtsim("accuracy --quick --scene cornell --fidelity-scenes cornell interior --out-dir " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(read_text(dir / "accuracy.json"));
  std::map<std::string, std::map<std::string, nlohmann::json>> by_scene;  // scene -> level -> point
  for (const auto& p : j["fidelity"]) by_scene[p["scene"]][p["level"]] = p;
  ASSERT_EQ(by_scene.size(), 2u) << j["fidelity"].dump();
  const double tolerance = j["tolerances"]["cycles_and_dram"];
  std::string why;
  for (const auto& rec : j["recommendations"])
    if (rec["topic"] == "cycles and DRAM bytes") why = rec["why"];
  ASSERT_FALSE(why.empty());
  EXPECT_NE(why.find("2 scenes (cornell, interior)"), std::string::npos) << why;
  for (const auto& [scene, levels] : by_scene) {
    ASSERT_EQ(levels.size(), 3u) << scene;
    EXPECT_EQ(levels.at("cycle")["cycle_error"].get<double>(), 0.0) << scene << ": its own reference";
    for (const char* level : {"functional", "lt"}) {
      const double worst = std::max(std::fabs(levels.at(level)["cycle_error"].get<double>()),
                                    std::fabs(levels.at(level)["dram_error"].get<double>()));
      const bool named = why.find(std::string(level) + " on " + scene + " (") != std::string::npos;
      EXPECT_EQ(named, worst > tolerance) << level << " on " << scene << ", worst " << worst << ": " << why;
    }
  }
  // The fidelity rows of the CSV carry their own scene.
  const std::string csv = read_text(dir / "accuracy.csv");
  EXPECT_NE(csv.find("\ninterior,fidelity,"), std::string::npos) << csv.substr(0, 400);
  std::filesystem::remove_all(dir);
  const CliResult bad = run_rtsim("accuracy --quick --scene cornell --fidelity-scenes no-such-scene --out-dir " +
                                  dir.string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("no-such-scene"), std::string::npos) << bad.output;
}
