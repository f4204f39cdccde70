// Campaign files: parsing, sweep expansion and job identity.
#include <rtsim/reports/campaign.h>
#include <rtsim/reports/simulation_job.h>

#include <rtsim/builder/build.h>
#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/scene_registry.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

namespace rtsim {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Guards against a typo ("step = 0.0001") expanding into millions of processes.
constexpr size_t kMaxValuesPerAxis = 10000;
constexpr size_t kMaxJobs = 200000;

const char* const kAxes[] = {"scene",      "builder", "node_format", "camera", "preset", "fidelity", "seed",
                             "resolution", "ao",      "ao_cutoff",   "frames", "diffuse_bounces",
                             "opaque",     "instanced"};

// One axis value as the text passed on the command line. Integers stay integers;
// reals use the shortest text that reads back to the same double.
std::string scalar_text(const json& v, const std::string& where) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number_integer()) return std::to_string(v.get<int64_t>());
  if (v.is_number_unsigned()) return std::to_string(v.get<uint64_t>());
  if (v.is_number_float()) {
    const double d = v.get<double>();
    if (!std::isfinite(d)) throw InputError(where, "values must be finite");
    return json(d).dump();
  }
  throw InputError(where, "values must be strings, numbers or booleans, not " +
                              std::string(v.type_name()));
}

// A range table: {from, to, step} (arithmetic, inclusive) or {from, to, factor}
// (geometric, inclusive). Integer endpoints and step give integer values.
std::vector<json> expand_range(const json& range, const std::string& where) {
  for (auto it = range.begin(); it != range.end(); ++it)
    if (it.key() != "from" && it.key() != "to" && it.key() != "step" && it.key() != "factor")
      throw InputError(where, "unknown range key '" + it.key() +
                                  "' (a range is {from, to, step} or {from, to, factor})");
  if (!range.contains("from") || !range.contains("to") ||
      range.contains("step") == range.contains("factor"))
    throw InputError(where, "a range needs from, to and exactly one of step or factor");
  for (const char* k : {"from", "to", "step", "factor"})
    if (range.contains(k) && !range[k].is_number())
      throw InputError(where, std::string("range '") + k + "' must be a number");
  const bool integral = range["from"].is_number_integer() && range["to"].is_number_integer() &&
                        (range.contains("factor") ? range["factor"].is_number_integer()
                                                  : range["step"].is_number_integer());
  const double from = range["from"].get<double>(), to = range["to"].get<double>();
  if (!std::isfinite(from) || !std::isfinite(to) || to < from)
    throw InputError(where, "range needs finite from <= to");
  std::vector<json> values;
  auto push = [&](double v) {
    if (values.size() >= kMaxValuesPerAxis)
      throw InputError(where, "range expands to more than " + std::to_string(kMaxValuesPerAxis) +
                                  " values");
    if (integral)
      values.emplace_back(static_cast<int64_t>(std::llround(v)));
    else
      values.emplace_back(v);
  };
  // Tolerance so that 0.1-steps reach their end point despite rounding.
  const double slack = 1e-9 * std::max(1.0, std::fabs(to));
  if (range.contains("step")) {
    const double step = range["step"].get<double>();
    if (!(step > 0)) throw InputError(where, "range step must be > 0");
    const double count = std::floor((to - from) / step + 1e-9);
    if (count + 1 > double(kMaxValuesPerAxis))
      throw InputError(where, "range expands to more than " + std::to_string(kMaxValuesPerAxis) +
                                  " values");
    for (int64_t i = 0; i <= int64_t(count); ++i) push(from + double(i) * step);
  } else {
    const double factor = range["factor"].get<double>();
    if (!(factor > 1)) throw InputError(where, "range factor must be > 1");
    if (!(from > 0)) throw InputError(where, "a geometric range needs from > 0");
    for (double v = from; v <= to + slack; v *= factor) push(v);
  }
  return values;
}

// An axis: a scalar, a list of scalars or a range table.
std::vector<json> axis_values(const json& v, const std::string& where) {
  std::vector<json> out;
  if (v.is_array()) {
    if (v.empty()) throw InputError(where, "an empty list would make no jobs");
    for (const json& e : v) {
      if (e.is_object()) {
        for (json& r : expand_range(e, where)) out.push_back(std::move(r));
      } else {
        scalar_text(e, where);  // type check
        out.push_back(e);
      }
    }
  } else if (v.is_object()) {
    out = expand_range(v, where);
  } else {
    scalar_text(v, where);
    out.push_back(v);
  }
  if (out.size() > kMaxValuesPerAxis)
    throw InputError(where, "more than " + std::to_string(kMaxValuesPerAxis) + " values");
  return out;
}

// The hardware overrides table, flattened to dotted keys. A table that looks like a
// range ({from, ...}) is a leaf; any other table is a level of the dotted key.
void flatten_overrides(const json& table, const std::string& prefix, const std::string& where_prefix,
                       std::map<std::string, std::vector<json>>& out) {
  for (auto it = table.begin(); it != table.end(); ++it) {
    const std::string key = prefix.empty() ? it.key() : prefix + "." + it.key();
    const std::string where = where_prefix + key + "'";
    if (it.value().is_object() && !it.value().contains("from")) {
      flatten_overrides(it.value(), key, where_prefix, out);
      continue;
    }
    // "l2.size_bytes" = 1 and l2.size_bytes = 2 are two TOML keys but one override.
    if (out.count(key))
      throw InputError(where, "is set twice (once as a quoted dotted key, once as a table); "
                              "keep one");
    out[key] = axis_values(it.value(), where);
  }
}

struct Sweep {
  std::map<std::string, std::vector<json>> axes;       // axis name -> values
  std::map<std::string, std::vector<json>> overrides;  // dotted hardware key -> values
  std::map<std::string, std::vector<json>> build;      // builder parameter key -> values
};

// Reads the axes and the `set` table of one [sweep] or [[group]] table.
void read_sweep(ConfigTable& table, const std::string& section, Sweep& sweep) {
  for (const char* axis : kAxes)
    if (table.has(axis))
      sweep.axes[axis] = axis_values(table.raw(axis), table.where(axis));
  if (table.has("set")) {
    const json& set = table.raw("set");
    if (!set.is_object()) throw InputError(table.where("set"), "must be a table of dotted keys");
    std::map<std::string, std::vector<json>> flat;
    flatten_overrides(set, "", table.file() + ": key '" + section + ".set.", flat);
    for (auto& [k, v] : flat) sweep.overrides[k] = std::move(v);
  }
  // Builder parameters (builder_registry.h) as axes: build.max_leaf_size = [1, 2, 4, 8].
  if (table.has("build")) {
    const json& build = table.raw("build");
    if (!build.is_object()) throw InputError(table.where("build"), "must be a table of builder parameters");
    for (auto it = build.begin(); it != build.end(); ++it) {
      const std::string where = table.file() + ": key '" + section + ".build." + it.key() + "'";
      if (!find_builder_parameter(it.key()) || it.key() == "width" || it.key() == "threads")
        throw InputError(where, "is not a builder parameter (docs/builders.md lists them)");
      sweep.build[it.key()] = axis_values(it.value(), where);
    }
  }
}

// Camera names: a built-in scene's, or a descriptor's [[camera]] names. Cameras a
// mesh suggests (spawnN) are only known once the mesh is loaded, so they pass.
void check_camera(const CampaignJob& job, const std::string& camera, const std::string& where) {
  std::vector<std::string> names;
  if (is_procedural_scene(job.scene)) {
    for (const Camera& c : make_procedural_scene(job.scene).cameras) names.push_back(c.name);
  } else {
    const std::vector<fs::path> files =
        scene_source_files(job.scene_path.empty() ? job.scene : job.scene_path.string());
    if (files.empty()) return;
    const json doc = parse_config_file(files.front());
    if (doc.is_object() && doc.contains("camera") && doc["camera"].is_array())
      for (const json& c : doc["camera"])
        if (c.is_object() && c.contains("name") && c["name"].is_string()) names.push_back(c["name"].get<std::string>());
    if (camera.rfind("spawn", 0) == 0) return;
  }
  if (std::find(names.begin(), names.end(), camera) == names.end()) {
    std::string known;
    for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
    throw InputError(where, "scene '" + job.scene + "' has no camera '" + camera + "' (cameras: " + known + ")");
  }
}

// Builders, scenes and cameras are checked by name when the campaign is read, so
// that a typo stops the campaign before its first job, not in every job.
void check_names(const Campaign& campaign, const std::map<std::string, std::string>& unknown_scenes,
                 const std::string& fname) {
  if (!unknown_scenes.empty())
    throw InputError(fname + ": key 'scene'", unknown_scenes.begin()->second);
  const std::vector<std::string> builders = builder_names();
  std::set<std::pair<std::string, std::string>> cameras_checked;
  std::set<std::string> builders_checked;
  for (const CampaignJob& job : campaign.jobs) {
    if (builders_checked.insert(job.builder).second &&
        std::find(builders.begin(), builders.end(), job.builder) == builders.end()) {
      std::string known;
      for (const std::string& b : builders) known += (known.empty() ? "" : ", ") + b;
      throw InputError(fname + ": key 'builder'", "unknown builder '" + job.builder + "' (known: " + known + ")");
    }
    // The workload's camera and the tree's (build.camera), each once per scene.
    std::vector<std::pair<std::string, std::string>> named;  // camera, key
    if (!job.camera.empty()) named.push_back({job.camera, "camera"});
    if (job.build_settings.count("camera")) named.push_back({job.build_settings.at("camera"), "build.camera"});
    for (const auto& [camera, key] : named)
      if (cameras_checked.insert({job.scene, camera}).second) check_camera(job, camera, fname + ": key '" + key + "'");
  }
}

bool looks_like_path(const std::string& s) {
  auto ends_with = [&](const char* tail) {
    const std::string t(tail);
    return s.size() > t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
  };
  return s.find('/') != std::string::npos || ends_with(".toml") || ends_with(".json");
}

}  // namespace

std::string content_hash_hex(const std::string& bytes) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

std::string file_hash_hex(const fs::path& file) {
  return content_hash_hex(read_input_file(file, kMaxDataFileBytes));
}

const std::string& CampaignJob::tree_camera() const {
  auto it = build_settings.find("camera");
  return it == build_settings.end() ? camera : it->second;
}

std::vector<std::string> CampaignJob::simulate_arguments(const fs::path& out_dir,
                                                         const fs::path& hardware_file) const {
  SimulationJob job;
  job.scene = scene_path.empty() ? scene : scene_path.string();
  job.builder = builder;
  job.fidelity = fidelity;
  job.config = !hardware_file.empty() ? hardware_file.string()
               : preset_path.empty()  ? preset
                                      : preset_path.string();
  job.seed = seed;
  job.out_dir = out_dir;
  job.camera = camera;
  job.resolution = resolution;
  job.ao_rays = ao_rays;
  job.ao_cutoff = ao_cutoff;
  job.frames = frames > 0 ? uint32_t(frames) : 0;
  job.diffuse_bounces = diffuse_bounces;
  job.opaque = opaque;
  job.instanced = instanced;
  job.node_format = node_format;
  // With a hardware file the overrides are in it.
  if (hardware_file.empty()) job.overrides.assign(overrides.begin(), overrides.end());
  job.build_settings.assign(build_settings.begin(), build_settings.end());
  return job.arguments();
}

namespace {

void toml_table(const json& object, const std::string& path, std::string& out) {
  for (auto it = object.begin(); it != object.end(); ++it)
    if (!it.value().is_object()) out += it.key() + " = " + it.value().dump() + "\n";
  for (auto it = object.begin(); it != object.end(); ++it)
    if (it.value().is_object()) {
      const std::string sub = path.empty() ? it.key() : path + "." + it.key();
      out += "\n[" + sub + "]\n";
      toml_table(it.value(), sub, out);
    }
}

}  // namespace

const json* json_at_path(const json& object, const std::string& dotted) {
  const json* node = &object;
  for (size_t start = 0;;) {
    const size_t dot = dotted.find('.', start);
    const std::string part = dotted.substr(start, dot == std::string::npos ? dot : dot - start);
    if (!node->is_object() || !node->contains(part)) return nullptr;
    node = &node->at(part);
    if (dot == std::string::npos) return node;
    start = dot + 1;
  }
}

std::string json_to_toml(const json& object) {
  std::string out;
  toml_table(object, "", out);
  return out;
}

const CampaignJob* Campaign::find(const std::string& key) const {
  for (const CampaignJob& j : jobs)
    if (j.key == key) return &j;
  return nullptr;
}

Campaign load_campaign(const fs::path& file, const std::string& revision) {
  return parse_campaign(parse_config_file(file), file, revision);
}

namespace {

// The name is a folder's (rtsim-campaigns/<name>): "." and ".." would put the
// campaign beside its file or above, and a name past what a file system takes in
// one path component fails every command.
void check_campaign_name(const std::string& name, const std::string& fname) {
  constexpr size_t kMaxCampaignName = 200;
  const bool control = std::any_of(name.begin(), name.end(),
                                   [](char ch) { return static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f; });
  if (name.empty() || control || name == "." || name == ".." ||
      name.find_first_of("/\\ \t\n'\"") != std::string::npos)
    throw InputError(fname + ": key 'campaign.name'",
                     "must be a non-empty name without spaces, quotes, slashes or control characters, "
                     "and not . or ..");
  if (name.size() > kMaxCampaignName)
    throw InputError(fname + ": key 'campaign.name'",
                     "is " + std::to_string(name.size()) + " characters long; at most " +
                         std::to_string(kMaxCampaignName) + " (it names a folder)");
}

// [sweep] over the defaults, then each [[group]] over [sweep]; one group "default"
// when there are none.
std::vector<std::pair<std::string, Sweep>> read_groups(ConfigTable& root) {
  Sweep base;
  base.axes["preset"] = {json("mobile")};
  base.axes["fidelity"] = {json("functional")};
  base.axes["seed"] = {json(1)};
  {
    ConfigTable sweep = root.table("sweep");
    read_sweep(sweep, "sweep", base);
    sweep.finish();
  }
  std::vector<std::pair<std::string, Sweep>> groups;
  for (ConfigTable& g : root.array_of_tables("group")) {
    Sweep s = base;
    const std::string name = g.string("name");
    if (name.empty()) throw InputError(g.where("name"), "must not be empty");
    for (const auto& [n, _] : groups)
      if (n == name) throw InputError(g.where("name"), "group '" + name + "' is defined twice");
    read_sweep(g, "group", s);
    g.finish();
    groups.emplace_back(name, std::move(s));
  }
  if (groups.empty()) groups.emplace_back("default", base);
  return groups;
}

// A group's dimensions: every axis, override ("set:" key) and builder parameter
// ("build:" key) with its values, the named axes in the order people read labels.
using SweepDim = std::pair<std::string, const std::vector<json>*>;
std::vector<SweepDim> sweep_dims(const Sweep& sweep) {
  std::vector<SweepDim> dims;
  for (const auto& [k, v] : sweep.axes) dims.emplace_back(k, &v);
  for (const auto& [k, v] : sweep.overrides) dims.emplace_back("set:" + k, &v);
  for (const auto& [k, v] : sweep.build) dims.emplace_back("build:" + k, &v);
  auto rank = [](const std::string& k) {
    for (size_t i = 0; i < std::size(kAxes); ++i)
      if (k == kAxes[i]) return i;
    return std::size(kAxes);
  };
  std::stable_sort(dims.begin(), dims.end(),
                   [&](const auto& a, const auto& b) { return rank(a.first) < rank(b.first); });
  return dims;
}

std::string job_label(const CampaignJob& job) {
  std::string label = job.scene + "/" + job.builder + (job.camera.empty() ? "" : "/" + job.camera) + "/" +
                      job.preset + "/" + job.fidelity + "/seed" + std::to_string(job.seed);
  if (!job.resolution.empty()) label += "/" + job.resolution;
  if (job.ao_rays >= 0) label += "/ao" + std::to_string(job.ao_rays);
  if (!job.ao_cutoff.empty()) label += "/aocut" + job.ao_cutoff;
  if (job.frames > 0) label += "/frames" + std::to_string(job.frames);
  if (job.diffuse_bounces >= 0) label += "/diffuse" + std::to_string(job.diffuse_bounces);
  if (job.opaque) label += "/opaque";
  if (job.instanced) label += "/instanced";
  if (!job.node_format.empty()) label += "/" + job.node_format;
  for (const auto& [k, v] : job.overrides) label += "/" + k + "=" + v;
  for (const auto& [k, v] : job.build_settings) label += "/build." + k + "=" + v;
  return label;
}

// Expands the groups into jobs. The hashes of the inputs and the checked hardware
// configurations are shared by all of a campaign's jobs.
class JobExpander {
 public:
  JobExpander(const std::string& fname, const fs::path& base_dir, const std::string& revision)
      : fname_(fname), base_dir_(base_dir), revision_(revision) {}

  void expand_group(const std::string& group_name, const Sweep& sweep, Campaign& campaign);
  const std::map<std::string, std::string>& unknown_scenes() const { return unknown_scenes_; }

 private:
  // A job being made, with its values as its key sees them.
  struct Draft {
    CampaignJob job;
    json resolved = json::object();
    std::map<std::string, json> typed_overrides;
  };
  std::string resolve_input(const std::string& value, const std::string& where, fs::path& path, bool must_be_file);
  const json& hardware_for(CampaignJob& job, const std::map<std::string, json>& values, const std::string& where);
  std::string scene_hash(const CampaignJob& job);
  void apply_value(Draft& draft, const std::string& name, const json& value, const std::string& where);
  void drop_plain_values(Draft& draft, const std::string& where);
  void identify(Draft& draft, const std::string& where);

  const std::string fname_;
  const fs::path base_dir_;
  const std::string revision_;
  std::map<std::string, std::string> input_hash_;  // inputs named by path: an edited preset file changes the keys
  std::map<std::string, json> checked_;            // merged TOML -> resolved hardware configuration
  std::map<std::string, std::string> scene_hashes_;
  std::map<std::string, std::string> unknown_scenes_;  // scene -> why, refused after the expansion, once
  std::set<std::string> seen_;
};

std::string JobExpander::resolve_input(const std::string& value, const std::string& where, fs::path& path,
                                       bool must_be_file) {
  if (!must_be_file && !looks_like_path(value)) return "";
  fs::path p = fs::path(value).is_absolute() ? fs::path(value) : base_dir_ / value;
  if (!is_file(p)) {
    if (!must_be_file) return "";
    throw InputError(where, "'" + value + "' is not a file (relative paths start at " + base_dir_.string() + ")");
  }
  path = fs::absolute(p).lexically_normal();
  auto [it, fresh] = input_hash_.emplace(path.string(), "");
  if (fresh) it->second = file_hash_hex(path);
  return it->second;
}

// The hardware configuration of a job: its preset (a name or a file) merged with the
// overrides, checked once per distinct combination against the model's parameter
// table, so a misspelt key stops the campaign before any job runs.
const json& JobExpander::hardware_for(CampaignJob& job, const std::map<std::string, json>& values,
                                      const std::string& where) {
  json merged = json::object();
  if (!job.preset_path.empty()) merged = parse_config_file(job.preset_path);
  else merged["preset"] = job.preset;
  for (const auto& [key, value] : values) {
    json* node = &merged;
    size_t start = 0;
    for (;;) {
      const size_t dot = key.find('.', start);
      const std::string part = key.substr(start, dot == std::string::npos ? dot : dot - start);
      if (node->is_null()) *node = json::object();
      if (!node->is_object()) throw InputError(where, "override '" + key + "' descends into a value, not a table");
      if (dot == std::string::npos) {
        (*node)[part] = value;
        break;
      }
      node = &(*node)[part];
      start = dot + 1;
    }
  }
  const std::string text = json_to_toml(merged);
  auto it = checked_.find(text);
  if (it == checked_.end()) {
    try {
      const sim::HardwareConfig config =
          values.empty()
              ? sim::load_hardware_config(job.preset_path.empty() ? job.preset : job.preset_path.string())
              : sim::parse_hardware_config(text, "hardware overrides");
      it = checked_.emplace(text, json::parse(sim::to_json(config))).first;
    } catch (const InputError& e) {
      throw InputError(where + ", preset '" + job.preset + "'", e.what());
    }
  }
  job.hardware_toml = values.empty() ? std::string() : text;
  return it->second;
}

// The content hash of each distinct scene (scene_registry.h); a scene that cannot
// be found is noted, and refused after the expansion.
std::string JobExpander::scene_hash(const CampaignJob& job) {
  const std::string lookup = job.scene_path.empty() ? job.scene : job.scene_path.string();
  auto it = scene_hashes_.find(lookup);
  if (it != scene_hashes_.end()) return it->second;
  std::string h;
  try {
    h = scene_files_hash(lookup);
  } catch (const InputError& e) {
    unknown_scenes_.emplace(job.scene, e.what());
  }
  return scene_hashes_.emplace(lookup, h).first->second;
}

// An integer axis value in [lo, hi], or a message naming the key and the range.
int64_t integer_in(const json& v, int64_t lo, int64_t hi, const std::string& where, const std::string& what) {
  if (!v.is_number_integer() || v.get<int64_t>() < lo || v.get<int64_t>() > hi)
    throw InputError(where, what + " must be integers in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v.get<int64_t>();
}

// One dimension's value into the job: an override, a builder parameter, or a named
// axis, each checked where it is read.
void JobExpander::apply_value(Draft& draft, const std::string& name, const json& v, const std::string& w) {
  CampaignJob& job = draft.job;
  const std::string value = scalar_text(v, w);
  if (name.rfind("set:", 0) == 0) {
    job.overrides[name.substr(4)] = value;
    draft.typed_overrides[name.substr(4)] = v;
    return;
  }
  if (name.rfind("build:", 0) == 0) {
    const std::string key = name.substr(6);
    BuildParams check;  // the value must parse and lie in range
    set_build_parameter(check, key, value, fname_ + ": key 'build.");
    job.build_settings[key] = value;
    return;
  }
  draft.resolved[name] = value;
  if (name == "scene") {
    job.scene = value;
    resolve_input(value, w, job.scene_path, false);
    if (job.scene_path.empty() && looks_like_path(value)) {  // a scene folder (scene.toml inside)
      const fs::path p = fs::path(value).is_absolute() ? fs::path(value) : base_dir_ / value;
      if (is_folder(p)) job.scene_path = fs::absolute(p).lexically_normal();
    }
    // Every file the scene is read from, by content: an edited mesh makes new keys.
    const std::string h = scene_hash(job);
    if (!h.empty()) draft.resolved["scene_files_hash"] = h;
  } else if (name == "builder") {
    job.builder = value;
  } else if (name == "camera") {
    job.camera = value;
  } else if (name == "preset") {
    job.preset = value;
    const std::string h = resolve_input(value, w, job.preset_path, false);
    if (!h.empty()) draft.resolved["preset_file_hash"] = h;
  } else if (name == "fidelity") {
    if (value != "functional" && value != "lt" && value != "cycle")
      throw InputError(w, "'" + value + "' is not a fidelity level (functional, lt, cycle)");
    job.fidelity = value;
  } else if (name == "seed") {
    if (!v.is_number_integer() || v.get<int64_t>() < 0) throw InputError(w, "seeds must be integers >= 0");
    job.seed = v.get<uint64_t>();
  } else if (name == "resolution") {
    uint32_t wdt = 0, hgt = 0;
    if (!parse_resolution_text(value, wdt, hgt))
      throw InputError(w, "'" + value + "' is not a resolution WxH (1..16384)");
    job.resolution = value;
  } else if (name == "ao") {
    job.ao_rays = integer_in(v, 0, 1024, w, "AO ray counts");
  } else if (name == "node_format") {
    node_format(value, w);  // names the formats when unknown
    job.node_format = value;
    // The tree and the memory image both follow it: part of the hardware.
    draft.typed_overrides["memory.node_format"] = json(value);
  } else if (name == "ao_cutoff") {
    if (!v.is_number() || !(v.get<double>() > 0) || v.get<double>() > AoSettings::kMaxCutoffRelative)
      throw InputError(w, "AO ray lengths must be numbers in (0, 10] (x scene diagonal)");
    job.ao_cutoff = value;
  } else if (name == "frames") {
    job.frames = integer_in(v, 1, 1000, w, "frames");
  } else if (name == "diffuse_bounces") {
    job.diffuse_bounces = integer_in(v, 0, kMaxDiffuseBounces, w, "diffuse bounces");
  } else if (name == "opaque") {
    if (!v.is_boolean()) throw InputError(w, "opaque must be true or false (alpha-tested materials as opaque)");
    job.opaque = v.get<bool>();
    if (!job.opaque) draft.resolved.erase(name);  // the default: the plain run, its key unchanged
  } else if (name == "instanced") {
    if (!v.is_boolean())
      throw InputError(w, "instanced must be true or false (the scene with its instances: a two-level tree)");
    job.instanced = v.get<bool>();
    if (!job.instanced) draft.resolved.erase(name);  // the default: the flat scene, its key unchanged
  }
}

// A value equal to the default is the plain run: an override at the preset's value,
// a node format that is the preset's, a builder parameter at the builder's default.
// The job is the same (its key does not change), and now it says so: reports count
// it as the plain run and find it in every sweep.
void JobExpander::drop_plain_values(Draft& draft, const std::string& where) {
  CampaignJob& job = draft.job;
  const json& preset_hardware = hardware_for(job, {}, where);
  for (auto it = draft.typed_overrides.begin(); it != draft.typed_overrides.end();) {
    const json* at_preset = json_at_path(preset_hardware, it->first);
    if (!at_preset || *at_preset != it->second) {
      ++it;
      continue;
    }
    if (it->first == "memory.node_format") draft.resolved.erase("node_format");
    job.overrides.erase(it->first);
    it = draft.typed_overrides.erase(it);
  }
  for (auto it = job.build_settings.begin(); it != job.build_settings.end();) {
    // The builder's seed defaults to the workload's and its camera to the
    // workload's: those are not constants to compare with.
    if (it->first == "seed" || it->first == "camera") {
      ++it;
      continue;
    }
    BuildParams plain, set;
    plain.builder = set.builder = job.builder;
    set_build_parameter(set, it->first, it->second);
    if (build_params_json(plain) == build_params_json(set)) {
      it = job.build_settings.erase(it);
    } else {
      ++it;
    }
  }
}

// The job's identity is its resolved configuration: the full hardware configuration
// (preset and overrides applied), not how it was spelt, so "mobile" with
// l2.size_bytes at its preset value is the same job as plain "mobile".
void JobExpander::identify(Draft& draft, const std::string& where) {
  CampaignJob& job = draft.job;
  // A format set as an override builds the tree for it too, as the axis does.
  if (job.node_format.empty() && job.overrides.count("memory.node_format"))
    job.node_format = job.overrides.at("memory.node_format");
  draft.resolved["set"] = json(job.overrides);
  if (!job.build_settings.empty()) draft.resolved["build"] = json(job.build_settings);  // absent: old campaigns keep their keys
  json identity = draft.resolved;
  for (const char* spelling : {"preset", "preset_file_hash", "set"}) identity.erase(spelling);
  identity["hardware"] = hardware_for(job, draft.typed_overrides, where);
  // A preset with a wide node format builds its trees for that width too (the
  // job's key already holds the format, through the hardware).
  if (job.node_format.empty()) {
    const std::string format = identity["hardware"].at("memory").at("node_format");
    if (format != sim::HardwareConfig{}.node_format) job.node_format = format;
  }
  job.resolved = draft.resolved;
  // json objects keep keys sorted, so dump() is canonical.
  job.config_hash = content_hash_hex(identity.dump());
  job.key = content_hash_hex(identity.dump() + "\nrevision=" + revision_);
  job.label = job_label(job);
}

void JobExpander::expand_group(const std::string& group_name, const Sweep& sweep, Campaign& campaign) {
  const std::string where = fname_ + ": group '" + group_name + "'";
  if (!sweep.axes.count("scene") || !sweep.axes.count("builder"))
    throw InputError(where, "needs 'scene' and 'builder' (in [sweep] or the group)");
  const std::vector<SweepDim> dims = sweep_dims(sweep);
  double total = 1;
  for (const auto& d : dims) total *= double(d.second->size());
  if (total + double(campaign.jobs.size()) > double(kMaxJobs))
    throw InputError(where, "expands to more than " + std::to_string(kMaxJobs) + " jobs");

  // A mixed-radix counter over the dimensions, the last one fastest.
  std::vector<size_t> index(dims.size(), 0);
  for (bool done = false; !done;) {
    Draft draft;
    draft.job.group = group_name;
    for (size_t d = 0; d < dims.size(); ++d)
      apply_value(draft, dims[d].first, (*dims[d].second)[index[d]], fname_ + ": key '" + dims[d].first + "'");
    // The AO ray length is the workload's and, for the builders that cast AO rays,
    // the tree's (unless the campaign sets the builder's own cutoff).
    CampaignJob& job = draft.job;
    if (!job.ao_cutoff.empty() && !job.build_settings.count("ao_cutoff_relative") &&
        parameter_used_by(*find_builder_parameter("ao_cutoff_relative"), job.builder))
      job.build_settings["ao_cutoff_relative"] = job.ao_cutoff;
    drop_plain_values(draft, where);
    identify(draft, where);
    if (seen_.insert(job.key).second) campaign.jobs.push_back(std::move(job));

    // Advance the odometer; when every digit wraps, the group is complete.
    size_t d = dims.size();
    for (;;) {
      if (d == 0) {
        done = true;
        break;
      }
      --d;
      if (++index[d] < dims[d].second->size()) break;
      index[d] = 0;
    }
  }
  campaign.groups.push_back(group_name);
}

}  // namespace

Campaign parse_campaign(const json& document, const fs::path& file_in, const std::string& revision) {
  const fs::path file = fs::absolute(file_in).lexically_normal();
  const std::string fname = file_in.string();
  Campaign campaign;
  campaign.file = file;
  campaign.revision = revision;

  ConfigTable root(document, fname);
  {
    ConfigTable meta = root.table("campaign");
    campaign.name = meta.string("name", file.stem().string());
    campaign.description = meta.string("description", "");
    meta.finish();
  }
  check_campaign_name(campaign.name, fname);
  const std::vector<std::pair<std::string, Sweep>> groups = read_groups(root);
  root.finish();

  JobExpander expander(fname, file.parent_path(), revision);
  for (const auto& [group_name, sweep] : groups) expander.expand_group(group_name, sweep, campaign);
  check_names(campaign, expander.unknown_scenes(), fname);
  return campaign;
}

}  // namespace rtsim
