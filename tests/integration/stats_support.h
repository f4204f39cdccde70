#pragma once
// What the integration tests read back from a run: stats.json as dotted keys, and
// a scratch folder per test process.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>

#include <unistd.h>

inline std::filesystem::path scratch_folder(const std::string& suite, const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("rtsim_" + suite + "_" + std::to_string(getpid()) + "_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// stats.json as "a.b.c" -> the JSON value.
inline void flatten_stats_json(const nlohmann::json& j, const std::string& prefix,
                               std::map<std::string, nlohmann::json>& out) {
  if (j.is_object() && j.contains("value") && j.contains("unit")) {
    out[prefix] = j.at("value");
    return;
  }
  for (auto it = j.begin(); it != j.end(); ++it)
    flatten_stats_json(it.value(), prefix.empty() ? it.key() : prefix + "." + it.key(), out);
}

inline std::map<std::string, nlohmann::json> read_stats(const std::filesystem::path& dir) {
  std::ifstream in(dir / "stats.json");
  std::map<std::string, nlohmann::json> out;
  flatten_stats_json(nlohmann::json::parse(in), "", out);
  return out;
}

inline double stat_number(const std::map<std::string, nlohmann::json>& s, const std::string& key) {
  auto it = s.find(key);
  if (it == s.end()) throw std::runtime_error("no stat " + key);
  return it->second.get<double>();
}
