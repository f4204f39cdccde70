// Scene descriptors (TOML or JSON) through load_scene_descriptor: the descriptor
// sits in a scratch folder next to a small OBJ mesh ("mesh.obj") and a closed,
// inward-facing unit cube ("box.obj") it may name. A scene that loads is then
// traced as one 2x2 frame at the documented bounce limit (kMaxBounces, fewer
// where max_frame_rays says the frame would pass 4096 rays): a closed mirror box
// must end (--bounces 256 wrapped an 8-bit counter and never stopped:
// tests/fuzz-regressions/scene_descriptor/mirror-box-*).
#include "fuzz_support.h"

#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/workloads/descriptor.h>

RTSIM_FUZZ_TARGET(scene_descriptor) {
  using namespace rtsim::fuzz;
  if (size == 0) return 0;
  static const bool meshes_written = [] {
    write_text(scratch_dir() / "mesh.obj",
               "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n");
    // Faces wound to face the inside.
    write_text(scratch_dir() / "box.obj",
               "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
               "f 1 2 3\nf 1 3 4\nf 5 8 7\nf 5 7 6\nf 1 5 6\nf 1 6 2\n"
               "f 4 3 7\nf 4 7 8\nf 1 4 8\nf 1 8 5\nf 2 6 7\nf 2 7 3\n");
    return true;
  }();
  (void)meshes_written;
  const bool toml = data[0] & 1;
  const std::filesystem::path file = scratch_dir() / (toml ? "scene.toml" : "scene.json");
  write_bytes(file, data + 1, size - 1);
  expect_only_input_errors([&] {
    const rtsim::Scene scene = rtsim::load_scene_descriptor(file);
    if (scene.triangle_count() == 0 || scene.triangle_count() > 4096 || scene.cameras.empty()) return;
    rtsim::EffectSettings settings;
    settings.width = settings.height = 2;
    settings.max_depth = rtsim::kMaxBounces;
    while (settings.max_depth > 0 &&
           rtsim::max_frame_rays(scene, rtsim::plan_effects(scene, settings), 4) > 4096)
      --settings.max_depth;
    if (rtsim::max_frame_rays(scene, rtsim::plan_effects(scene, settings), 4) > 4096) return;  // AO alone
    rtsim::BuildParams params;
    params.threads = 1;
    const rtsim::Bvh bvh = rtsim::build_bvh(scene, params);
    const rtsim::MemoryImage image(scene, bvh);
    const rtsim::TraversalContext context(scene, bvh, image);
    const rtsim::FrameRun run = rtsim::run_frame(context, scene.default_camera(), settings, nullptr, 1);
    (void)rtsim::shaded_image(scene, run);
  });
  return 0;
}
