#pragma once
// Small pieces every subcommand parses or prints the same way: one spelling per
// concept (docs in README "The command line"), deprecated spellings that still
// work with a warning, output paths checked before any work, errors that name
// the flag the user typed.
#include <rtsim/builder/build.h>
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/workloads/scene.h>

#include <CLI/CLI.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace rtsim::cli {

// The default image size of every subcommand that traces (trace, simulate, table1,
// scenes render).
inline const char* const kDefaultResolution = "256x256";

// "WxH" with 1..16384 each, digits only; InputError naming `option` otherwise.
void parse_resolution(const std::string& text, uint32_t& width, uint32_t& height,
                      const std::string& option = "--res");

std::string hex64(uint64_t value);  // 16 lower-case hex digits

// ---- flags and their deprecated spellings

// The spelling the user typed for a flag: `canonical` unless a deprecated alias
// of it was used. Error messages name this, so they name what is on the screen.
std::string typed_flag(const std::string& canonical);
// Prints, once per process and alias, "rtsim: warning: OLD is deprecated; use NEW"
// on stderr, and remembers that OLD stands for NEW (typed_flag).
void warn_deprecated(const std::string& old_name, const std::string& new_name);

// `old_name` as a second spelling of the option `new_name`, writing into the same
// variable; listed under "Deprecated" in --help. `explanation` is appended to the
// warning when the old spelling meant something else elsewhere.
template <class T>
CLI::Option* add_deprecated_option(CLI::App* cmd, const std::string& old_name,
                                   const std::string& new_name, T& variable,
                                   const std::string& explanation = "") {
  CLI::Option* o = cmd->add_option(old_name, variable, "deprecated: use " + new_name);
  const std::string first = old_name.substr(0, old_name.find(','));
  std::string shown = first;
  for (size_t at = 0; at != std::string::npos;) {  // the long name for the message
    const size_t next = old_name.find(',', at);
    const std::string part = old_name.substr(at, next == std::string::npos ? next : next - at);
    if (part.rfind("--", 0) == 0) shown = part;
    at = next == std::string::npos ? next : next + 1;
  }
  o->check(CLI::Validator(
      [shown, new_name, explanation](std::string&) {
        warn_deprecated(shown + explanation, new_name);
        return std::string();
      },
      "", "deprecated"));
  o->group("Deprecated (kept for one release)");
  return o;
}

// ---- output paths, checked before any work

// An output folder: created if missing, then checked by writing a probe file;
// InputError naming `flag` if it is a file or cannot be written. If this run
// created it and the command fails (keep() never called), it is removed again
// when empty, so a failed command leaves no trace.
class OutputFolder {
 public:
  OutputFolder() = default;
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;
  ~OutputFolder();
  void prepare(const std::filesystem::path& path, const std::string& flag);
  void keep() { keep_ = true; }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::filesystem::path created_;  // the outermost folder this run created
  bool keep_ = false;
};

// A folder a command writes into for good (a campaign's folder): prepare() and
// keep() of OutputFolder in one call.
void check_output_folder(const std::filesystem::path& path, const std::string& flag);

// The tree cache a campaign or claim shares trees through, checked before any job:
// a path that is a file (or under one) is refused, naming `flag`; a folder that
// cannot be created or written gives a warning and no cache (every job builds its
// own tree in its folder). Empty in, empty out.
// The results cache is checked the same way (`what` it is, and what happens `without` it).
std::filesystem::path usable_tree_cache(const std::filesystem::path& cache, const std::string& flag,
                                        const std::string& what = "tree cache",
                                        const std::string& without = "every job builds its own tree in its folder");

// An output file: not a folder, and its folder (the first one that exists on the
// way up; the rest is created when the file is written) can be written.
void check_output_file(const std::filesystem::path& path, const std::string& flag);

// ---- build parameters

// "sah, median, sbvh, ..." for --help texts: every builder build_bvh knows.
std::string builder_list();

// check_build_params with the flags' names: "--sbvh-budget: must be >= 1", not
// the field "sbvh_reference_budget".
void check_build_flags(const BuildParams& params);

// What trace and simulate run on: a scene, one of its cameras and a tree, either
// built (builder name, seed, the camera for OSAH) or loaded from a saved file that
// must belong to the scene. Scene first: the camera points into it.
struct Workload {
  Scene scene;
  const Camera* camera = nullptr;
  BuildParams params;  // params.builder is the saved tree's builder when loaded
  BuildReport report;  // empty when loaded
  Bvh bvh;
};
// --instanced's help, one text for every command that takes it.
inline constexpr const char* kInstancedHelp =
    "the scene with its instances: a BLAS per mesh and a TLAS over\nthe instances, walked with an instance "
    "transform (XFM op)\nper instance entered (docs/machine.md \"Instancing\");\ndefault: the flat scene";

// scene/camera empty: the defaults. bvh_file non-empty: load instead of build.
// shuffle_seed != 0: the scene's faces are permuted first (shuffle_triangles), a
// check that no result depends on the file's face order. `threads` limits the
// build too (0: all cores).
// The tree is built for `node_format` (apply_node_format); a loaded tree must fit it.
// `build_settings`: builder parameters as KEY=VALUE (--build-set), applied before the
// node format; not allowed with a saved tree. `ao_cutoff_relative` > 0 replaces the
// scene's AO ray length (x diagonal) before the build: the workload's and the
// builders' AO rays (simulate --ao-cutoff).
// `builder_given`: --builder was on the command line; with a saved tree it must then
// name the tree's builder (a tree labelled sah must not carry median's numbers).
// `check_scene` runs after the scene is loaded, before the tree is built or read.
// `opaque`: alpha-tested materials become opaque (--opaque): the same geometry
// without the any-hit stage, for comparison. `instanced`: the scene with its
// instances (SceneForm::Instanced), built as a two-level tree; a flat scene is refused.
void load_workload(Workload& out, const std::string& scene, const std::string& camera,
                   const std::string& builder, uint64_t seed, const std::string& bvh_file,
                   uint64_t shuffle_seed = 0, uint32_t threads = 0,
                   const std::string& node_format = "bvh2-64",
                   const std::vector<std::string>& build_settings = {},
                   float ao_cutoff_relative = -1, bool builder_given = false,
                   const std::function<void(const Scene&)>& check_scene = {}, bool opaque = false,
                   bool instanced = false);

// ---- the frame: trace's and simulate's image flags, checked alike

// --bounces (and its old spelling --max-depth), --diffuse-bounces and
// --russian-roulette, as trace and simulate both take them; the options, in that order.
std::vector<const CLI::Option*> add_bounce_flags(CLI::App* cmd, uint32_t& bounces, uint32_t& diffuse_bounces,
                                                 bool& russian_roulette);

// --spp 1..1024, --ao -1..1024, --bounces 0..kMaxBounces (the reflection/refraction
// depth Ray::bounce can count), before any work.
void check_frame_flags(const EffectSettings& settings);
// Refuses a frame whose rays could need more memory than the limit (rtsim/workloads/
// host.h), from the scene's materials and lights: --res x --spp x (AO, shadow and
// bounce rays per primary ray). `frames` copies are kept (simulate --frames: 1).
void check_frame_memory(const Scene& scene, const EffectSettings& settings);
// With a replayed ray file (--rays-in) the rays are fixed: these flags, each one
// that generates or spawns rays, would be ignored; refused when given.
void refuse_with_rays_in(const std::vector<const CLI::Option*>& flags);

// --node-format NAME: checks the name (a message listing the formats, naming the
// flag) and returns it; empty value: `fallback` (the hardware's memory.node_format).
std::string node_format_flag(const std::string& value, const std::string& fallback,
                             const std::string& flag = "--node-format");

}  // namespace rtsim::cli
