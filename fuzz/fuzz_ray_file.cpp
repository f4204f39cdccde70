// Ray files (read_ray_file takes a path), then what `rtsim trace --rays-in F
// --out-dir D` does with them: the rays traced against the cornell scene and
// every picture drawn from the results (a shadow ray whose parent missed crashed
// shaded_image: tests/fuzz-regressions/ray_file/shadow-parent-misses-*).
#include "fuzz_support.h"

#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/core/ray_file.h>
#include <rtsim/workloads/procedural.h>

#include <memory>

namespace rtsim::fuzz {

// Built once per process: the scene the seed's rays were made for, and its tree.
struct RayFileWorld {
  Scene scene = make_procedural_scene("cornell");
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;
  RayFileWorld() {
    BuildParams params;
    params.threads = 1;
    bvh = build_bvh(scene, params);
    image = std::make_unique<MemoryImage>(scene, bvh);
    context = std::make_unique<TraversalContext>(scene, bvh, *image);
  }
};

}  // namespace rtsim::fuzz

RTSIM_FUZZ_TARGET(ray_file) {
  using namespace rtsim::fuzz;
  static RayFileWorld world;
  const std::filesystem::path file = scratch_dir() / "fuzz.rays";
  write_bytes(file, data, size);
  expect_only_input_errors([&] {
    rtsim::RaySet set = rtsim::read_ray_file(file);
    // The pictures of a 4x4 image (pixel ids past it are the pictures' to skip).
    const rtsim::FrameRun run = rtsim::run_rays(*world.context, std::move(set.rays), 4, 4, nullptr, 1);
    (void)rtsim::ops_per_pixel(run);
    (void)rtsim::ao_image(run);
    (void)rtsim::shaded_image(world.scene, run);
  });
  return 0;
}
