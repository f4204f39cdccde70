#pragma once
// Scene descriptor files (TOML or JSON, same keys). See docs/scene-descriptor.md.
#include <rtsim/workloads/scene.h>

#include <filesystem>

namespace rtsim {

// Loads the descriptor and every mesh it names (paths relative to the descriptor),
// applies transforms and materials, validates. Throws InputError naming the file
// and the key on any problem.
Scene load_scene_descriptor(const std::filesystem::path& path);

}  // namespace rtsim
