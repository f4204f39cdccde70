#include "cli_util.h"

#include <rtsim/builder/bvh_file.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/scene_registry.h>

#include <cstdio>

namespace rtsim::cli {

void parse_resolution(const std::string& text, uint32_t& width, uint32_t& height,
                      const std::string& option) {
  unsigned w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%u%c%u%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') ||
      w == 0 || h == 0 || w > 16384 || h > 16384)
    throw InputError(option, "expected WxH with 1..16384 each, got '" + text + "'");
  width = w;
  height = h;
}

std::string hex64(uint64_t value) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(value));
  return buf;
}

void load_workload(Workload& out, const std::string& scene, const std::string& camera,
                   const std::string& builder, uint64_t seed, const std::string& bvh_file,
                   uint64_t shuffle_seed) {
  out.scene = load_scene(scene.empty() ? default_scene_name() : scene);
  if (shuffle_seed != 0) shuffle_triangles(out.scene, shuffle_seed);
  out.camera = camera.empty() ? &out.scene.default_camera() : &out.scene.camera(camera);
  out.params = BuildParams{};
  out.params.builder = builder;
  out.params.seed = seed;
  out.params.camera = out.camera->name;
  out.report = BuildReport{};
  if (bvh_file.empty()) {
    out.bvh = build_bvh(out.scene, out.params, &out.report);
  } else {
    // A saved tree (rtsim build --out) is replayed as it is, so that campaign and
    // table1 runs use exactly the tree that was measured.
    BvhFileHeader header;
    out.bvh = load_bvh(bvh_file, &out.scene, &header);
    out.params.builder = header.builder;
  }
}

}  // namespace rtsim::cli
