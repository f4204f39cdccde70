// Real-scene fetching without the network: the catalogue, unknown names, and
// idempotence (a finished scene folder is returned without downloading).
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/fetch.h>

#include <gtest/gtest.h>

#include <fstream>
#include <set>

namespace fs = std::filesystem;
using namespace rtsim;

TEST(Fetch, CatalogueListsTheSevenScenesOfIssueTwoWithExpectedCounts) {
  const std::vector<RealSceneInfo> scenes = real_scene_catalogue();
  std::set<std::string> names;
  for (const RealSceneInfo& s : scenes) {
    names.insert(s.name);
    EXPECT_GT(s.expected_triangles, 0u) << s.name;
    EXPECT_FALSE(s.description.empty()) << s.name;
    EXPECT_FALSE(s.licence.empty()) << s.name;
  }
  EXPECT_EQ(names, (std::set<std::string>{"dragon-small", "dragon", "cg57", "oacmpdm1", "mines",
                                          "black_forest", "maple"}));
}

TEST(Fetch, UnknownNamesAreInputErrorsListingTheKnownOnes) {
  const fs::path cache = fs::temp_directory_path() / "rtsim_test_fetch_unknown";
  try {
    fetch_real_scene("teapot", cache);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("teapot"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("black_forest"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(cache / "teapot"));
}

TEST(Fetch, AFinishedSceneIsNotFetchedAgain) {
  const fs::path cache = fs::temp_directory_path() / "rtsim_test_fetch_done";
  fs::remove_all(cache);
  fs::create_directories(cache / "dragon-small");
  std::ofstream(cache / "dragon-small" / "scene.toml") << "name = \"dragon-small\"\n";
  // No download happens (there is no .downloads folder afterwards).
  EXPECT_EQ(fetch_real_scene("dragon-small", cache), cache / "dragon-small" / "scene.toml");
  EXPECT_FALSE(fs::exists(cache / ".downloads"));
  fs::remove_all(cache);
}
