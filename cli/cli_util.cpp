#include "cli_util.h"

#include <rtsim/builder/bvh_file.h>
#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/scene_registry.h>

#include <cstdio>

namespace rtsim::cli {

void parse_resolution(const std::string& text, uint32_t& width, uint32_t& height,
                      const std::string& option) {
  if (!parse_resolution_text(text, width, height))
    throw InputError(option, "expected WxH with 1.." + std::to_string(kMaxResolutionSide) +
                                 " each (digits only), got '" + text + "'");
}

std::string hex64(uint64_t value) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(value));
  return buf;
}

void load_workload(Workload& out, const std::string& scene, const std::string& camera,
                   const std::string& builder, uint64_t seed, const std::string& bvh_file) {
  out.scene = load_scene(scene.empty() ? default_scene_name() : scene);
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
