#pragma once
// Strict reading of configuration files (TOML or JSON, the same keys either way):
// every error names the file and the dotted key, unknown keys are refused.
// Used by scene descriptors, hardware configurations and campaign files.
#include <rtsim/workloads/geometry.h>
#include <rtsim/workloads/numbers.h>  // parse_unsigned, parse_resolution_text

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace rtsim {

// Parses .toml (toml++) or .json (nlohmann) into JSON; InputError with the file,
// line and column on a syntax error, and for a key repeated in one JSON object.
// The file is read bounded (read_input_file, kMaxConfigFileBytes).
nlohmann::json parse_config_file(const std::filesystem::path& path);
nlohmann::json parse_config_text(const std::string& text, const std::string& file_name, bool toml);

// A view on one table of a config. Reading a key marks it used; finish() throws
// for any key that was never read ("file: key 'x.y' is unknown").
class ConfigTable {
 public:
  ConfigTable(const nlohmann::json& table, std::string file, std::string path = "");

  bool has(const std::string& key) const;
  std::string string(const std::string& key, const std::string& fallback);
  std::string string(const std::string& key);  // required
  double number(const std::string& key, double fallback, double min, double max);
  double number(const std::string& key, double min, double max);  // required
  int64_t integer(const std::string& key, int64_t fallback, int64_t min, int64_t max);
  bool boolean(const std::string& key, bool fallback);
  vec3 vector3(const std::string& key, vec3 fallback);
  vec3 vector3(const std::string& key);  // required
  ConfigTable table(const std::string& key);  // {} if absent
  std::vector<ConfigTable> array_of_tables(const std::string& key);  // [] if absent
  const nlohmann::json& raw(const std::string& key);  // marks used; null if absent
  void finish() const;  // unknown keys -> InputError

  std::string where(const std::string& key) const;  // "file: key 'a.b'"
  const std::string& file() const { return file_; }

 private:
  const nlohmann::json* value(const std::string& key);
  const nlohmann::json& table_;
  std::string file_, path_;
  std::set<std::string> used_;
};

}  // namespace rtsim
