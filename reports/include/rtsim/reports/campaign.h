#pragma once
// A campaign: a declarative sweep (TOML or JSON) over scenes x builders x cameras x
// hardware presets/overrides x fidelity levels x seeds, expanded into jobs. Each job
// is one `rtsim simulate` process; its identity (key) is a hash of its resolved
// configuration and the simulator binary's revision, so rerunning a finished job is
// a no-op and a new binary reruns everything. The file format is in docs/campaigns.md.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace rtsim {

struct CampaignJob {
  std::string key;          // hash(resolved configuration + revision), 16 hex digits
  std::string config_hash;  // hash(resolved configuration), 16 hex digits
  std::string label;        // "interior/sah/view1/mobile/functional/seed1[/l2.size_bytes=...]"
  std::string group;        // first named group that produced the job ("default" if none)

  std::string scene, builder, preset, fidelity;
  std::string camera;       // "" = the scene's first camera
  uint64_t seed = 1;
  std::string resolution;   // "WxH" or "" (simulate's default)
  int64_t ao_rays = -1;     // AO rays per primary hit, < 0: simulate's default
  std::string ao_cutoff;    // AO ray length x scene diagonal (--ao-cutoff); "" = the scene's
  int64_t frames = -1;      // frames of the same rays (stats of the last), < 1: simulate's default
  int64_t diffuse_bounces = -1;  // diffuse path bounces per primary hit (--diffuse-bounces), < 0: none
  bool opaque = false;           // alpha-tested materials as opaque (--opaque)
  bool instanced = false;        // the scene with its instances, a two-level tree (--instanced)
  std::string node_format;  // node record format the tree is built for; "" = the preset's
  std::map<std::string, std::string> overrides;  // dotted hardware key -> value text
  // Builder parameters (builder_registry.h) -> value text: --build-set KEY=VALUE. A
  // "seed" here is the builder's seed; `seed` above stays the workload's.
  std::map<std::string, std::string> build_settings;
  // The hardware configuration the job runs with when it has overrides: the preset
  // (name or file) merged with the overrides, as TOML; empty without overrides.
  // Validated against the model's parameter table when the campaign is loaded.
  std::string hardware_toml;

  // Absolute paths for inputs named by path in the campaign (empty: a name).
  std::filesystem::path preset_path, scene_path;

  nlohmann::json resolved;  // canonical description hashed into config_hash

  // The camera the tree is built for: the builder's `camera` setting (build.camera,
  // e.g. to trace a tree from a camera it was not built for) or else the workload's.
  const std::string& tree_camera() const;

  // Arguments after the binary: simulate --scene ... --out DIR. With `hardware_file`
  // (hardware_toml written there) it is the --config; without, overrides go as --set k=v.
  std::vector<std::string> simulate_arguments(const std::filesystem::path& out_dir,
                                              const std::filesystem::path& hardware_file = {}) const;
};

struct Campaign {
  std::string name;
  std::string description;
  std::filesystem::path file;  // absolute
  std::string revision;        // the simulator binary's revision the keys were made with
  std::vector<std::string> groups;
  std::vector<CampaignJob> jobs;  // in expansion order, unique keys

  const CampaignJob* find(const std::string& key) const;  // nullptr if absent
};

// Reads and expands a campaign file. `revision` is the job binary's revision (part of
// every key). Throws InputError naming the file and key for anything wrong.
Campaign load_campaign(const std::filesystem::path& file, const std::string& revision);
Campaign parse_campaign(const nlohmann::json& document, const std::filesystem::path& file,
                        const std::string& revision);

// The value at a dotted key ("l2.size_bytes") inside nested objects, or nullptr.
const nlohmann::json* json_at_path(const nlohmann::json& object, const std::string& dotted);

// A JSON object as TOML (tables for objects, inline arrays, JSON string escapes).
std::string json_to_toml(const nlohmann::json& object);

// Stable 64-bit content hash (FNV-1a) as 16 lowercase hex digits.
std::string content_hash_hex(const std::string& bytes);
std::string file_hash_hex(const std::filesystem::path& file);  // InputError if unreadable

}  // namespace rtsim
