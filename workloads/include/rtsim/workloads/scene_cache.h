#pragma once
// A binary image of a loaded scene, so that a scene parsed once (dragon's ASCII PLY
// takes seconds) loads in milliseconds afterwards: every campaign job, claim run and
// table1 reloads its scene. The image is keyed by the content hash of the scene's
// input files (scene_files_hash) and the image format's version, so an edited mesh
// or descriptor is parsed again; it carries a checksum of its body, so a damaged
// image is detected and rebuilt, never trusted.
//
// The image holds the scene as its loader parsed it, before validation (instanced
// where the scene is: meshes and instances); load_scene validates it in the form
// asked (scene_in_form), so both forms come from one image.
//
// Where: $RTSIM_CACHE/scene-images/<key>.v<format>.scene. RTSIM_SCENE_CACHE=off turns it off.
#include <rtsim/workloads/scene.h>

#include <filesystem>
#include <optional>
#include <string>

namespace rtsim {

// The image's bytes for a scene, and the scene back from them (nullopt if the bytes
// are not a whole, undamaged image of this key).
std::string scene_image(const Scene& scene, const std::string& key);
std::optional<Scene> scene_from_image(const std::string& bytes, const std::string& key);

// The image file of a key, and whether the cache is on (RTSIM_SCENE_CACHE).
std::filesystem::path scene_image_path(const std::string& key);
bool scene_cache_enabled();

}  // namespace rtsim
