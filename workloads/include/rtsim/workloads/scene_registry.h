#pragma once
// Finds a scene by name: a built-in procedural scene, a fetched real scene in the
// cache folder, or a path to a scene descriptor (.toml/.json) or a mesh file.
#include <rtsim/workloads/scene.h>

#include <filesystem>
#include <string>

namespace rtsim {

// The cache folder for fetched scenes: $RTSIM_CACHE, else $XDG_CACHE_HOME/rtsim,
// else ~/.cache/rtsim.
std::filesystem::path scene_cache_dir();
std::string default_scene_name();  // "interior"
Scene load_scene(const std::string& name_or_path);  // validated; throws InputError
std::vector<std::string> known_scene_names();  // procedural + fetchable real scenes

}  // namespace rtsim
