// SuperTuxKart tracks: there is no from-bytes entry point, so the input becomes
// the track folder's scene.xml (and, after a line "--quads--", its quads.xml),
// next to a small OBJ model "m.obj" that the XML may reference.
#include "fuzz_support.h"

#include <rtsim/workloads/mesh_loader.h>

RTSIM_FUZZ_TARGET(stk_track) {
  using namespace rtsim::fuzz;
  static const std::filesystem::path track = [] {
    const std::filesystem::path dir = scratch_dir() / "track";
    std::filesystem::create_directories(dir);
    write_text(dir / "m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    return dir;
  }();
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t split = input.find("\n--quads--\n");
  write_text(track / "scene.xml", input.substr(0, split));
  if (split != std::string::npos) write_text(track / "quads.xml", input.substr(split + 11));
  else std::filesystem::remove(track / "quads.xml");
  expect_only_input_errors([&] { rtsim::load_stk_track(track); });
  return 0;
}
