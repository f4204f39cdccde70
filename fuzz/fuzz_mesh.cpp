// Mesh files through the assimp path: PLY (checked against its own header first)
// and OBJ, from bytes. Input starting with "ply" is a .ply file, anything else
// an .obj. assimp itself runs in a child process (mesh_loader.h), so an input on
// which assimp aborts must come back as an InputError, never end this process.
#include "fuzz_support.h"

#include <rtsim/workloads/mesh_loader.h>

#include <cstring>

RTSIM_FUZZ_TARGET(mesh) {
  const bool ply = size >= 3 && std::memcmp(data, "ply", 3) == 0;
  const std::filesystem::path file = rtsim::fuzz::scratch_dir() / (ply ? "mesh.ply" : "mesh.obj");
  rtsim::fuzz::write_bytes(file, data, size);
  rtsim::fuzz::expect_only_input_errors([&] { rtsim::load_mesh(file); });
  return 0;
}
