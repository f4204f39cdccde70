// Replays every saved fuzz input - the crashes scripts/fuzz.sh found (kept under
// tests/fuzz-regressions/<target>/ once fixed) and the seed corpora
// (fuzz/seeds/<target>/) - through the same harness code the libFuzzer targets
// run, in the default build: a regression is a crash, a sanitizer report or an
// exception other than InputError.
#define RTSIM_FUZZ_REPLAY
#include "../../fuzz/fuzz_bvh_file.cpp"
#include "../../fuzz/fuzz_campaign.cpp"
#include "../../fuzz/fuzz_config_text.cpp"
#include "../../fuzz/fuzz_hardware_config.cpp"
#include "../../fuzz/fuzz_mesh.cpp"
#include "../../fuzz/fuzz_q3bsp.cpp"
#include "../../fuzz/fuzz_ray_file.cpp"
#include "../../fuzz/fuzz_scene_descriptor.cpp"
#include "../../fuzz/fuzz_spm.cpp"
#include "../../fuzz/fuzz_stk_track.cpp"

#include <rtsim/builder/build.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace {

namespace fs = std::filesystem;
using Harness = int (*)(const uint8_t*, size_t);

const std::map<std::string, Harness>& harnesses() {
  static const std::map<std::string, Harness> all = {
      {"bvh_file", rtsim_fuzz_bvh_file},
      {"campaign", rtsim_fuzz_campaign},
      {"config_text", rtsim_fuzz_config_text},
      {"hardware_config", rtsim_fuzz_hardware_config},
      {"mesh", rtsim_fuzz_mesh},
      {"q3bsp", rtsim_fuzz_q3bsp},
      {"ray_file", rtsim_fuzz_ray_file},
      {"scene_descriptor", rtsim_fuzz_scene_descriptor},
      {"spm", rtsim_fuzz_spm},
      {"stk_track", rtsim_fuzz_stk_track},
  };
  return all;
}

std::vector<fs::path> saved_inputs(const std::string& target) {
  std::vector<fs::path> files;
  for (const fs::path& root : {fs::path(RTSIM_SOURCE_DIR) / "tests/fuzz-regressions" / target,
                               fs::path(RTSIM_SOURCE_DIR) / "fuzz/seeds" / target})
    if (fs::is_directory(root))
      for (const auto& entry : fs::directory_iterator(root))
        if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

class FuzzRegressions : public testing::TestWithParam<std::string> {};

// Property: every saved input of the target runs through its harness without a
// crash and without any exception but InputError (which the harness absorbs).
TEST_P(FuzzRegressions, SavedInputsReplayCleanly) {
  const Harness harness = harnesses().at(GetParam());
  for (const fs::path& file : saved_inputs(GetParam())) {
    std::ifstream in(file, std::ios::binary);
    std::stringstream buffer;
    buffer << in.rdbuf();
    const std::string bytes = buffer.str();
    EXPECT_NO_THROW(harness(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()))
        << file;
  }
}

INSTANTIATE_TEST_SUITE_P(EveryTarget, FuzzRegressions,
                         testing::Values("bvh_file", "campaign", "config_text", "hardware_config", "mesh",
                                         "q3bsp", "ray_file", "scene_descriptor", "spm", "stk_track"));

// The seed that starts bvh_file on two-level trees is the instanced fuzz scene's
// own tree, loaded back whole; RTSIM_WRITE_FUZZ_SEEDS=1 writes it again (after a
// format change).
TEST(FuzzSeeds, TheTwoLevelSeedIsTheInstancedFuzzScenesTree) {
  const rtsim::Scene& scene = fuzz_instanced_scene();
  rtsim::BuildParams params;
  params.width = 4;
  const rtsim::Bvh bvh = rtsim::build_bvh(scene, params);
  ASSERT_TRUE(bvh.two_level());
  const fs::path seed = fs::path(RTSIM_SOURCE_DIR) / "fuzz/seeds/bvh_file/two-level.bvh";
  if (std::getenv("RTSIM_WRITE_FUZZ_SEEDS")) rtsim::save_bvh(seed, bvh, scene, params);
  const rtsim::Bvh loaded = rtsim::load_bvh(seed, &scene);
  EXPECT_EQ(loaded.tlas_nodes, bvh.tlas_nodes);
  EXPECT_EQ(loaded.blas_roots, bvh.blas_roots);
  EXPECT_EQ(loaded.prim_refs, bvh.prim_refs) << seed << " is stale: rerun with RTSIM_WRITE_FUZZ_SEEDS=1";
}

// Property: every folder of saved inputs belongs to a target (a misspelt folder
// would silently never replay).
TEST(FuzzRegressionFolders, NameKnownTargets) {
  for (const fs::path& root : {fs::path(RTSIM_SOURCE_DIR) / "tests/fuzz-regressions",
                               fs::path(RTSIM_SOURCE_DIR) / "fuzz/seeds"}) {
    if (!fs::is_directory(root)) continue;
    for (const auto& entry : fs::directory_iterator(root))
      if (entry.is_directory())
        EXPECT_TRUE(harnesses().count(entry.path().filename().string())) << entry.path();
  }
}

}  // namespace
