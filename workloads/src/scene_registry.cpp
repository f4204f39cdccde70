#include <rtsim/workloads/descriptor.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/scene_cache.h>
#include <rtsim/workloads/scene_registry.h>

#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/validate.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace rtsim {

std::filesystem::path scene_cache_dir() {
  std::filesystem::path dir;
  std::string from;  // what chose it, for a message
  if (const char* env = std::getenv("RTSIM_CACHE"); env && *env) {
    dir = env, from = "RTSIM_CACHE";
  } else if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) {
    dir = std::filesystem::path(xdg) / "rtsim", from = "XDG_CACHE_HOME";
  } else if (const char* home = std::getenv("HOME"); home && *home) {
    dir = std::filesystem::path(home) / ".cache" / "rtsim", from = "HOME";
  } else {
    dir = std::filesystem::current_path() / ".cache" / "rtsim", from = "the current folder";
  }
  // A cache that is a file would fail later as a file-system error deep in a command.
  if (path_exists(dir) && !is_folder(dir))
    throw InputError(from + " (the scene cache " + dir.string() + ")", "exists and is not a folder");
  return dir;
}

std::string default_scene_name() { return "interior"; }

namespace {
// A descriptor's input files, and a hash over their names and contents (below).
std::vector<std::filesystem::path> descriptor_source_files(const std::filesystem::path& descriptor);
std::string files_hash(const std::vector<std::filesystem::path>& files);

// The descriptor load_scene reads for a name that is not a built-in scene.
std::filesystem::path descriptor_to_load(const std::string& name_or_path) {
  const std::filesystem::path cached = scene_cache_dir() / name_or_path / "scene.toml";
  if (name_or_path.find('/') == std::string::npos && path_exists(cached)) return cached;
  const std::filesystem::path path(name_or_path);
  if (path_exists(path)) {
    if (is_folder(path) && path_exists(path / "scene.toml")) return path / "scene.toml";
    const std::string ext = path.extension().string();
    if (ext == ".toml" || ext == ".json") return path;
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
}  // namespace

Scene scene_in_form(Scene parsed, SceneForm form) {
  // Flat: flattened before validation, so that validation drops and counts the
  // world's triangles, as it did when the loaders made flat scenes.
  if (form == SceneForm::Flat && parsed.instanced()) parsed = flatten(parsed);
  validate_scene(parsed);
  return parsed;
}

Scene load_scene(const std::string& name_or_path, SceneForm form) {
  if (is_procedural_scene(name_or_path)) return make_procedural_scene(name_or_path, form);
  const std::filesystem::path descriptor = descriptor_to_load(name_or_path);
  if (!scene_cache_enabled()) return load_scene_descriptor(descriptor, form);
  // The image of these very input files, if one was written and is whole. It holds
  // the scene as parsed (instanced where the scene is), before validation: either
  // form is made from it.
  const std::string key = files_hash(descriptor_source_files(descriptor));
  const std::filesystem::path image = scene_image_path(key);
  if (is_file(image)) {
    if (std::optional<Scene> scene = scene_from_image(read_input_file(image, kMaxDataFileBytes), key)) {
      scene->source = descriptor.string();  // where it is now, not where it was parsed
      return scene_in_form(std::move(*scene), form);
    }
    std::fprintf(stderr, "rtsim: the scene image %s is damaged; parsing the scene again\n", image.string().c_str());
  }
  Scene parsed = read_scene_descriptor(descriptor);
  const std::string bytes = scene_image(parsed, key);
  Scene scene = scene_in_form(std::move(parsed), form);  // a scene that does not validate is not kept
  // Best effort: a cache that cannot be written costs the next load its parse, nothing else.
  try {
    std::filesystem::create_directories(image.parent_path());
    write_file_atomic(image, bytes);
  } catch (const std::exception& e) {
    static bool told = false;
    if (!told) std::fprintf(stderr, "rtsim: warning: the scene image cannot be written (%s); scenes are parsed every time\n", e.what());
    told = true;
  }
  return scene;
}

}  // namespace rtsim

namespace rtsim {

std::vector<std::string> known_scene_names() {
  std::vector<std::string> names = procedural_scene_names();
  for (const std::string& n : instanced_procedural_scene_names()) names.push_back(n);
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(scene_cache_dir(), ec))
    if (path_exists(entry.path() / "scene.toml"))
      names.push_back(entry.path().filename().string());
  return names;
}

}  // namespace rtsim

namespace rtsim {

namespace {

// The descriptor load_scene would read for this name ("" for a built-in scene).
std::filesystem::path descriptor_of(const std::string& name_or_path) {
  if (is_procedural_scene(name_or_path)) return {};
  const std::filesystem::path cached = scene_cache_dir() / name_or_path / "scene.toml";
  if (name_or_path.find('/') == std::string::npos && path_exists(cached)) return cached;
  const std::filesystem::path path(name_or_path);
  if (is_folder(path) && path_exists(path / "scene.toml")) return path / "scene.toml";
  if (is_file(path)) return path;
  throw InputError("scene '" + name_or_path + "'", "unknown: not a built-in scene, not fetched, not a file");
}

void add_folder_files(const std::filesystem::path& folder, std::vector<std::filesystem::path>& out) {
  std::error_code ec;
  std::vector<std::filesystem::path> files;
  for (auto it = std::filesystem::recursive_directory_iterator(folder, ec);
       !ec && it != std::filesystem::recursive_directory_iterator(); it.increment(ec))
    if (is_file(it->path())) files.push_back(it->path());
  std::sort(files.begin(), files.end());
  out.insert(out.end(), files.begin(), files.end());
}

std::vector<std::filesystem::path> descriptor_source_files(const std::filesystem::path& descriptor) {
  std::vector<std::filesystem::path> files = {descriptor};
  const nlohmann::json doc = parse_config_file(descriptor);
  if (!doc.is_object() || !doc.contains("mesh") || !doc["mesh"].is_array()) return files;
  for (const nlohmann::json& mesh : doc["mesh"]) {
    if (!mesh.is_object() || !mesh.contains("file") || !mesh["file"].is_string()) continue;
    const std::filesystem::path file = descriptor.parent_path() / mesh["file"].get<std::string>();
    if (is_folder(file)) {
      add_folder_files(file, files);
    } else if (file.filename() == "scene.xml") {
      add_folder_files(file.parent_path(), files);
    } else if (is_file(file)) {
      files.push_back(file);
      std::string ext = file.extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
      if (ext == ".obj") {  // materials live beside it
        std::istringstream lines(read_input_file(file, kMaxDataFileBytes));
        for (std::string line; std::getline(lines, line);)
          if (line.rfind("mtllib ", 0) == 0) {
            std::string name = line.substr(7);
            while (!name.empty() && (name.back() == '\r' || name.back() == ' ')) name.pop_back();
            if (is_file(file.parent_path() / name)) files.push_back(file.parent_path() / name);
          }
      }
    }
  }
  return files;
}

std::string files_hash(const std::vector<std::filesystem::path>& files) {
  if (files.empty()) return "";
  const std::filesystem::path base = files.front().parent_path();
  uint64_t h = 0x5343454E4546494Cull;
  for (const std::filesystem::path& f : files) {
    const std::string name = f.lexically_relative(base).generic_string();
    h = hash_bytes(h, name.data(), name.size());
    const uint64_t content = file_content_hash(f);
    h = hash_bytes(h, &content, sizeof content);
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(h));
  return text;
}

}  // namespace

std::vector<std::filesystem::path> scene_source_files(const std::string& name_or_path) {
  const std::filesystem::path descriptor = descriptor_of(name_or_path);
  if (descriptor.empty()) return {};
  return descriptor_source_files(descriptor);
}

std::string scene_files_hash(const std::string& name_or_path) { return files_hash(scene_source_files(name_or_path)); }

}  // namespace rtsim
