// Scene descriptors (TOML or JSON) through load_scene_descriptor: the descriptor
// sits in a scratch folder next to a small OBJ mesh ("mesh.obj") it may name.
#include "fuzz_support.h"

#include <rtsim/workloads/descriptor.h>

RTSIM_FUZZ_TARGET(scene_descriptor) {
  using namespace rtsim::fuzz;
  if (size == 0) return 0;
  static const bool mesh_written = [] {
    write_text(scratch_dir() / "mesh.obj",
               "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n");
    return true;
  }();
  (void)mesh_written;
  const bool toml = data[0] & 1;
  const std::filesystem::path file = scratch_dir() / (toml ? "scene.toml" : "scene.json");
  write_bytes(file, data + 1, size - 1);
  expect_only_input_errors([&] { rtsim::load_scene_descriptor(file); });
  return 0;
}
