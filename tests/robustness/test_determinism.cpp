// Determinism at the file level: the same inputs give byte-identical BVH files,
// ray files and stats across runs (separate processes) and thread counts.
// tests/builder and tests/model already compare trees and per-ray results in
// memory for several thread counts, and tests/model/test_sim_determinism.cpp
// compares `rtsim simulate` stats.json across two runs; these compare the bytes
// that leave the program.
#include "builder/scene_fixtures.h"
#include "robustness/robustness_support.h"

#include <rtsim/builder/bvh_file.h>
#include <rtsim/model/core/ray_file.h>
#include <rtsim/workloads/procedural.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace rtsim {
namespace {

namespace fs = std::filesystem;

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path scratch_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("rtsim-determinism-" + name + "-" +
                                                    std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Property: for every builder, the BVH file of a 20k-triangle soup is
// byte-identical for 1, 2 and all threads and for a second build.
TEST(RobustDeterminism, BvhFilesAreByteIdenticalAcrossRunsAndThreadCounts) {
  const fs::path dir = scratch_dir("bvh");
  const Scene scene = test::triangle_soup(20000, 13, 0.1f);
  for (const std::string& builder : builder_names()) {
    std::string first;
    int run = 0;
    for (uint32_t threads : {1u, 2u, 0u, 2u}) {
      BuildParams p;
      p.builder = builder;
      p.threads = threads;
      p.ao_rays = 4;
      p.osah_width = p.osah_height = 64;
      const fs::path file = dir / (builder + "-" + std::to_string(run++) + ".bvh");
      save_bvh(file, build_bvh(scene, p), scene, p);
      const std::string bytes = file_bytes(file);
      ASSERT_GT(bytes.size(), 100u);
      if (first.empty()) first = bytes;
      EXPECT_TRUE(bytes == first) << builder << ": threads " << threads << " gave other bytes";
    }
  }
  fs::remove_all(dir);
}

// Host-time figures (seconds, rays per second) legitimately differ; every other
// field of the stats must not.
void drop_host_time(nlohmann::json& j) {
  if (!j.is_object()) return;
  for (auto it = j.begin(); it != j.end();) {
    const std::string& key = it.key();
    if (key.find("seconds") != std::string::npos || key.find("per_second") != std::string::npos) {
      it = j.erase(it);
    } else {
      drop_host_time(*it);
      ++it;
    }
  }
}

std::string run_trace(const std::string& scene, uint32_t threads, const fs::path& rays_out) {
  const fs::path json = rays_out.string() + ".json";
  const std::string command = std::string(RTSIM_BINARY) + " trace --scene " + scene +
                              " --res 64x48 --spp 2 --threads " + std::to_string(threads) +
                              " --json --rays-out " + rays_out.string() + " > " + json.string();
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  nlohmann::json stats = nlohmann::json::parse(file_bytes(json));
  drop_host_time(stats);
  return stats.dump();
}

// Property: `rtsim trace` writes byte-identical ray files and identical stats
// (all but host time) for 1, 2 and all threads and for a repeated run, on a
// small and on the default-sized interior scene (primary, AO and shadow rays).
TEST(RobustDeterminism, RayFilesAndTraceStatsAreIdenticalAcrossRunsAndThreadCounts) {
  const fs::path dir = scratch_dir("rays");
  for (const std::string scene : {"cornell", "interior"}) {
    std::string first_rays, first_stats;
    int run = 0;
    for (uint32_t threads : {1u, 2u, 0u, 1u}) {
      const fs::path rays = dir / (scene + "-" + std::to_string(run++) + ".rays");
      const std::string stats = run_trace(scene, threads, rays);
      const std::string bytes = file_bytes(rays);
      ASSERT_GT(bytes.size(), 1000u) << scene;
      EXPECT_NE(stats.find("\"ops\""), std::string::npos);
      if (first_rays.empty()) first_rays = bytes, first_stats = stats;
      EXPECT_TRUE(bytes == first_rays) << scene << ": threads " << threads << " gave another ray file";
      EXPECT_EQ(stats, first_stats) << scene << ": threads " << threads;
    }
    // The file reads back into the same rays (a round trip of the bytes compared above).
    const RaySet set = read_ray_file(dir / (scene + "-0.rays"));
    EXPECT_GT(set.rays.size(), 64u * 48u * 2u);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rtsim
