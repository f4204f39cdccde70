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
// The form a scene is loaded in. Flat: every triangle in world space, as every
// scene was before instancing (the same content hash). Instanced: the meshes
// once each and the instances placing them (Scene::instances); a scene without
// instances comes flat (instanced() false) either way.
enum class SceneForm { Flat, Instanced };

// Validated; throws InputError. The flat form is flatten() of the scene as parsed,
// then validated (so validation sees, and reports, the world's triangles).
Scene load_scene(const std::string& name_or_path, SceneForm form = SceneForm::Flat);
// A loader's scene, as parsed (unvalidated), in the form asked, validated: what
// load_scene returns for it. The procedural scenes and descriptors use it.
Scene scene_in_form(Scene parsed, SceneForm form);
std::vector<std::string> known_scene_names();  // procedural + fetchable real scenes

// The files a scene is read from, found the way load_scene finds the scene: its
// descriptor, every mesh file it names (a folder mesh, e.g. a SuperTuxKart track:
// every regular file under it; an .obj: its mtllib files too). Empty for a
// built-in scene (its content is the binary's). InputError if the scene is unknown.
std::vector<std::filesystem::path> scene_source_files(const std::string& name_or_path);
// A hash over those files' names (relative to the descriptor) and contents, 16 hex
// digits; "" for a built-in scene. What changes when any input file of the scene does.
std::string scene_files_hash(const std::string& name_or_path);

}  // namespace rtsim
