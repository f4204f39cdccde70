#pragma once
// Scene descriptor files (TOML or JSON, same keys). See docs/scene-descriptor.md.
#include <rtsim/workloads/scene.h>
#include <rtsim/workloads/scene_registry.h>  // SceneForm

#include <filesystem>

namespace rtsim {

// Loads the descriptor and every mesh it names (paths relative to the descriptor),
// applies transforms and materials, validates, in the form asked (scene_in_form).
// Throws InputError naming the file and the key on any problem.
Scene load_scene_descriptor(const std::filesystem::path& path, SceneForm form = SceneForm::Flat);
// The scene as the descriptor describes it, unvalidated: each mesh once, in its own
// space, and instances placing them (none if it is one mesh placed untransformed).
// What the scene cache stores.
Scene read_scene_descriptor(const std::filesystem::path& path);

}  // namespace rtsim
