#pragma once
// Small pieces every subcommand parses or prints the same way.
#include <rtsim/builder/build.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <string>

namespace rtsim::cli {

// "WxH" with 1..16384 each; InputError naming `option` otherwise.
void parse_resolution(const std::string& text, uint32_t& width, uint32_t& height,
                      const std::string& option = "--res");

std::string hex64(uint64_t value);  // 16 lower-case hex digits

// What trace and simulate run on: a scene, one of its cameras and a tree, either
// built (builder name, seed, the camera for OSAH) or loaded from a saved file that
// must belong to the scene. Scene first: the camera points into it.
struct Workload {
  Scene scene;
  const Camera* camera = nullptr;
  BuildParams params;  // params.builder is the saved tree's builder when loaded
  BuildReport report;  // empty when loaded
  Bvh bvh;
};
// scene/camera empty: the defaults. bvh_file non-empty: load instead of build.
// shuffle_seed != 0: the scene's faces are permuted first (shuffle_triangles), a
// check that no result depends on the file's face order.
void load_workload(Workload& out, const std::string& scene, const std::string& camera,
                   const std::string& builder, uint64_t seed, const std::string& bvh_file,
                   uint64_t shuffle_seed = 0);

}  // namespace rtsim::cli
