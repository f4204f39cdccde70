#include "cli_util.h"

#include <nlohmann/json.hpp>

#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/scene_registry.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <set>

#include <fcntl.h>
#include <unistd.h>

namespace rtsim::cli {

namespace fs = std::filesystem;

void parse_resolution(const std::string& text, uint32_t& width, uint32_t& height,
                      const std::string& option) {
  if (!parse_resolution_text(text, width, height))
    throw InputError(typed_flag(option), "expected WxH with 1.." + std::to_string(kMaxResolutionSide) +
                                             " each (digits only), got '" + text + "'");
}

std::string hex64(uint64_t value) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(value));
  return buf;
}

namespace {
std::mutex g_flag_mutex;
std::map<std::string, std::string>& typed_spellings() {
  static std::map<std::string, std::string> spellings;  // canonical -> typed
  return spellings;
}
}  // namespace

std::string typed_flag(const std::string& canonical) {
  std::lock_guard<std::mutex> lock(g_flag_mutex);
  auto it = typed_spellings().find(canonical);
  return it == typed_spellings().end() ? canonical : it->second;
}

void warn_deprecated(const std::string& old_name, const std::string& new_name) {
  static std::set<std::string> warned;
  std::lock_guard<std::mutex> lock(g_flag_mutex);
  const std::string bare = old_name.substr(0, old_name.find(' '));
  typed_spellings()[new_name] = bare;
  if (!warned.insert(old_name).second) return;
  std::fprintf(stderr, "rtsim: warning: %s is deprecated; use %s (the old spelling goes in the next release)\n",
               old_name.c_str(), new_name.c_str());
}

// ---- output paths

namespace {

// Can files be created in `folder`? Answered by creating one (permission bits
// say nothing for root, read-only mounts or full disks).
std::string probe_writable(const fs::path& folder) {
  const fs::path probe = folder / (".rtsim-write-probe-" + std::to_string(::getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) return std::strerror(errno);
  ::close(fd);
  ::unlink(probe.c_str());
  return "";
}

}  // namespace

void OutputFolder::prepare(const fs::path& path, const std::string& flag) {
  const std::string name = typed_flag(flag) + " " + path.string();
  if (path.empty()) throw InputError(typed_flag(flag), "must name a folder");
  path_ = path;
  if (path_exists(path) && !is_folder(path))
    throw InputError(name, "exists and is not a folder");
  if (!is_folder(path)) {
    // The outermost missing folder is what this run creates (and removes on failure).
    fs::path first_missing = path;
    for (fs::path p = path; !p.empty() && !path_exists(p); p = p.parent_path()) {
      first_missing = p;
      if (p == p.parent_path()) break;
    }
    for (fs::path p = path.parent_path(); !p.empty(); p = p.parent_path()) {
      if (path_exists(p)) {
        if (!is_folder(p)) throw InputError(name, "'" + p.string() + "' is a file, not a folder");
        break;
      }
      if (p == p.parent_path()) break;
    }
    std::error_code ec;
    fs::create_directories(path, ec);
    if (ec) throw InputError(name, "cannot create the folder: " + ec.message());
    created_ = first_missing;
  }
  const std::string why = probe_writable(path);
  if (!why.empty()) throw InputError(name, "cannot write in this folder: " + why);
}

OutputFolder::~OutputFolder() {
  if (keep_ || created_.empty()) return;
  // Only empty folders go: whatever a failed command managed to write stays visible.
  std::error_code ec;
  for (fs::path p = path_;; p = p.parent_path()) {
    if (!fs::remove(p, ec) || ec) break;
    if (p == created_ || p == p.parent_path()) break;
  }
}

void check_output_folder(const fs::path& path, const std::string& flag) {
  OutputFolder folder;
  folder.prepare(path, flag);
  folder.keep();
}

fs::path usable_tree_cache(const fs::path& cache, const std::string& flag, const std::string& what,
                           const std::string& without) {
  if (cache.empty()) return cache;
  const std::string name = typed_flag(flag) + " " + cache.string();
  if (path_exists(cache) && !is_folder(cache)) throw InputError(name, "exists and is not a folder");
  for (fs::path p = cache.parent_path(); !p.empty(); p = p.parent_path()) {
    if (path_exists(p)) {
      if (!is_folder(p)) throw InputError(name, "'" + p.string() + "' is a file, not a folder");
      break;
    }
    if (p == p.parent_path()) break;
  }
  std::error_code ec;
  fs::create_directories(cache, ec);
  const std::string why = ec ? ec.message() : probe_writable(cache);
  if (why.empty()) return cache;
  std::fprintf(stderr, "rtsim: warning: %s: the %s cannot be written (%s); %s\n", name.c_str(), what.c_str(),
               why.c_str(), without.c_str());
  return {};
}

void check_output_file(const fs::path& path, const std::string& flag) {
  const std::string name = typed_flag(flag) + " " + path.string();
  if (path.empty()) throw InputError(typed_flag(flag), "must name a file");
  if (is_folder(path)) throw InputError(name, "is a folder; give a file name");
  fs::path folder = path.parent_path();
  if (folder.empty()) folder = ".";
  while (!path_exists(folder) && folder != folder.parent_path() && !folder.parent_path().empty())
    folder = folder.parent_path();
  if (!path_exists(folder)) folder = ".";
  if (!is_folder(folder)) throw InputError(name, "'" + folder.string() + "' is a file, not a folder");
  const std::string why = probe_writable(folder);
  if (!why.empty()) throw InputError(name, "cannot write in '" + folder.string() + "': " + why);
}

// ---- build parameters

std::string builder_list() {
  std::string names;
  for (const std::string& b : builder_names()) names += (names.empty() ? "" : ", ") + b;
  return names;
}

void check_build_flags(const BuildParams& params) {
  try {
    check_build_params(params);
  } catch (const InputError& e) {
    const std::string what = e.what();
    const size_t colon = what.find(": ");
    const BuilderParameter* p =
        colon == std::string::npos ? nullptr : find_builder_parameter(what.substr(0, colon));
    if (!p || p->flag.empty()) throw;
    throw InputError(typed_flag(p->flag) + what.substr(colon));
  }
}

std::vector<const CLI::Option*> add_bounce_flags(CLI::App* cmd, uint32_t& bounces, uint32_t& diffuse_bounces,
                                                 bool& russian_roulette) {
  return {cmd->add_option("--bounces", bounces, "reflection/refraction bounces (0.." + std::to_string(kMaxBounces) + ")")
              ->capture_default_str(),
          add_deprecated_option(cmd, "--max-depth", "--bounces", bounces,
                                " (the bounce count in trace and simulate; the BVH depth in build and table1)"),
          cmd->add_option("--diffuse-bounces", diffuse_bounces,
                          "diffuse path bounces per primary hit (0.." + std::to_string(kMaxDiffuseBounces) +
                              "; ray types diffuse1, ...)")
              ->capture_default_str(),
          cmd->add_flag("--russian-roulette", russian_roulette,
                        "a diffuse bounce past the first survives with the albedo")};
}

void check_frame_flags(const EffectSettings& settings) {
  if (settings.spp == 0 || settings.spp > 1024) throw InputError(typed_flag("--spp"), "must be 1..1024");
  if (settings.ao_samples < -1 || settings.ao_samples > 1024)
    throw InputError(typed_flag("--ao"), "must be 0..1024 (or -1: the scene decides)");
  if (settings.max_depth > kMaxBounces)
    throw InputError(typed_flag("--bounces"), "must be 0.." + std::to_string(kMaxBounces) + ", got " +
                                                  std::to_string(settings.max_depth));
  if (settings.diffuse_bounces > kMaxDiffuseBounces)
    throw InputError(typed_flag("--diffuse-bounces"), "must be 0.." + std::to_string(kMaxDiffuseBounces) +
                                                          " (a ray type per depth), got " +
                                                          std::to_string(settings.diffuse_bounces));
  if (settings.russian_roulette && settings.diffuse_bounces < 2)
    throw InputError(typed_flag("--russian-roulette"),
                     "ends diffuse paths from their second bounce on: give --diffuse-bounces 2 or more");
}

void check_frame_memory(const Scene& scene, const EffectSettings& settings) {
  const EffectPlan plan = plan_effects(scene, settings);
  const uint64_t primary = uint64_t(settings.width) * settings.height * settings.spp;
  const uint64_t rays = max_frame_rays(scene, plan, primary);
  check_memory_budget(saturating_mul(rays, sizeof(Ray) + sizeof(TraceResult)), "--res x --spp x --bounces x --diffuse-bounces",
                      "up to " + std::to_string(rays) + " rays: " + std::to_string(settings.width) + "x" +
                          std::to_string(settings.height) + " x " + std::to_string(settings.spp) +
                          " spp primary rays, each with " + std::to_string(plan.ao_samples) + " AO rays and " +
                          std::to_string(plan.max_depth) + " bounces and " + std::to_string(plan.diffuse_bounces) +
                          " diffuse bounces in scene '" + scene.name + "'");
}

void refuse_with_rays_in(const std::vector<const CLI::Option*>& flags) {
  for (const CLI::Option* flag : flags)
    if (flag->count() > 0)
      throw InputError(typed_flag(flag->get_name()),
                       "has no effect with --rays-in: the ray file fixes every ray (no rays are generated or "
                       "spawned); leave it out");
}

std::string node_format_flag(const std::string& value, const std::string& fallback,
                             const std::string& flag) {
  if (value.empty()) return fallback;
  node_format(value, typed_flag(flag));  // throws, listing the formats
  return value;
}

void load_workload(Workload& out, const std::string& scene, const std::string& camera,
                   const std::string& builder, uint64_t seed, const std::string& bvh_file,
                   uint64_t shuffle_seed, uint32_t threads, const std::string& node_format,
                   const std::vector<std::string>& build_settings, float ao_cutoff_relative,
                   bool builder_given, const std::function<void(const Scene&)>& check_scene, bool opaque,
                   bool instanced) {
  if (!bvh_file.empty() && !build_settings.empty())
    throw InputError("--build-set", "cannot change a saved tree (--bvh); build it with these settings");
  if (bvh_file.empty()) builder_info(builder, typed_flag("--builder"));  // before the scene is loaded
  out.scene = load_scene(scene.empty() ? default_scene_name() : scene,
                         instanced ? SceneForm::Instanced : SceneForm::Flat);
  if (instanced && !out.scene.instanced())
    throw InputError("--instanced", "scene '" + out.scene.name + "' has no instances (it is flat)");
  if (opaque) out.scene.make_opaque();
  if (check_scene) check_scene(out.scene);
  if (shuffle_seed != 0) shuffle_triangles(out.scene, shuffle_seed);
  if (ao_cutoff_relative > 0) out.scene.ao.cutoff_relative = ao_cutoff_relative;
  out.camera = camera.empty() ? &out.scene.default_camera() : &out.scene.camera(camera);
  out.params = BuildParams{};
  out.params.builder = builder;
  out.params.seed = seed;
  out.params.threads = threads;
  out.params.camera = out.camera->name;
  for (const std::string& setting : build_settings) apply_build_setting(out.params, setting, "--build-set");
  apply_node_format(out.params, rtsim::node_format(node_format));
  out.report = BuildReport{};
  if (bvh_file.empty()) {
    out.bvh = build_bvh(out.scene, out.params, &out.report);
  } else {
    // A saved tree (rtsim build --out) is replayed as it is, so that campaign and
    // table1 runs use exactly the tree that was measured.
    BvhFileHeader header;
    out.bvh = load_bvh(bvh_file, &out.scene, &header);
    if (builder_given && builder != header.builder)
      throw InputError("--builder", "'" + builder + "' does not match the saved tree (--bvh " + bvh_file +
                                        "), built by '" + header.builder + "'; leave --builder out");
    out.params.builder = header.builder;
    // The tree must have been built for the node format's width: a binary tree in
    // 6-wide records would run, but measure neither tree nor format.
    uint32_t built_width = 2;  // binary trees leave "width" out
    try {
      const nlohmann::json saved = nlohmann::json::parse(header.params_json);
      if (saved.is_object() && saved.contains("width")) built_width = saved.at("width").get<uint32_t>();
    } catch (const nlohmann::json::exception&) {
    }
    if (built_width != out.params.width)
      throw InputError("--bvh", bvh_file + " holds a tree built for width " + std::to_string(built_width) +
                                    "; node format " + rtsim::node_format(node_format).name +
                                    " needs width " + std::to_string(out.params.width) +
                                    " (rtsim build --node-format " + rtsim::node_format(node_format).name +
                                    ")");
  }
}

}  // namespace rtsim::cli
