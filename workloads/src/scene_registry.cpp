#include <rtsim/workloads/descriptor.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/scene_registry.h>

#include <cstdlib>

namespace rtsim {

std::filesystem::path scene_cache_dir() {
  if (const char* dir = std::getenv("RTSIM_CACHE"); dir && *dir) return dir;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return std::filesystem::path(xdg) / "rtsim";
  if (const char* home = std::getenv("HOME"); home && *home)
    return std::filesystem::path(home) / ".cache" / "rtsim";
  return std::filesystem::current_path() / ".cache" / "rtsim";
}

std::string default_scene_name() { return "interior"; }

Scene load_scene(const std::string& name_or_path) {
  if (is_procedural_scene(name_or_path)) return make_procedural_scene(name_or_path);
  const std::filesystem::path cached = scene_cache_dir() / name_or_path / "scene.toml";
  if (name_or_path.find('/') == std::string::npos && path_exists(cached))
    return load_scene_descriptor(cached);
  const std::filesystem::path path(name_or_path);
  if (path_exists(path)) {
    if (is_folder(path) && path_exists(path / "scene.toml"))
      return load_scene_descriptor(path / "scene.toml");
    const std::string ext = path.extension().string();
    if (ext == ".toml" || ext == ".json") return load_scene_descriptor(path);
    throw InputError(path.string(),
                     "not a scene descriptor (.toml/.json); write one that names this mesh "
                     "(see docs/scene-descriptor.md)");
  }
  std::string known;
  for (const std::string& n : known_scene_names()) known += (known.empty() ? "" : ", ") + n;
  throw InputError("scene '" + name_or_path + "'",
                   "unknown: not a built-in scene, not fetched into " + scene_cache_dir().string() +
                       " (try `rtsim scenes fetch " + name_or_path + "`), not a file. Known: " + known);
}

}  // namespace rtsim

namespace rtsim {

std::vector<std::string> known_scene_names() {
  std::vector<std::string> names = procedural_scene_names();
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(scene_cache_dir(), ec))
    if (path_exists(entry.path() / "scene.toml"))
      names.push_back(entry.path().filename().string());
  return names;
}

}  // namespace rtsim
