#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>

#include <toml++/toml.h>

#include <cmath>
#include <sstream>

namespace rtsim {

namespace {

// JSON allows a key twice in one object and nlohmann keeps the last silently;
// TOML refuses it. So that both spellings of a configuration mean the same, the
// JSON reader refuses it too: this parser callback notes the first repeated key,
// with the keys of the objects around it.
struct DuplicateKeyFinder {
  std::vector<std::set<std::string>> keys_per_level;
  std::vector<std::string> path;  // the key being read at each object level
  std::string duplicate;          // dotted path of the first repeated key

  bool operator()(int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    using Event = nlohmann::json::parse_event_t;
    if (event == Event::object_start) {
      keys_per_level.emplace_back();
      path.emplace_back();
    } else if (event == Event::object_end) {
      if (!keys_per_level.empty()) keys_per_level.pop_back(), path.pop_back();
    } else if (event == Event::key && !keys_per_level.empty()) {
      const std::string key = parsed.get<std::string>();
      path.back() = key;
      if (!keys_per_level.back().insert(key).second && duplicate.empty()) {
        for (const std::string& part : path) duplicate += (duplicate.empty() ? "" : ".") + part;
      }
    }
    return true;
  }
};

// toml++ nodes to JSON, keeping integers and floats apart.
nlohmann::json to_json(const toml::node& node) {
  if (const auto* t = node.as_table()) {
    nlohmann::json out = nlohmann::json::object();
    for (const auto& [k, v] : *t) out[std::string(k.str())] = to_json(v);
    return out;
  }
  if (const auto* a = node.as_array()) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& v : *a) out.push_back(to_json(v));
    return out;
  }
  if (const auto* v = node.as_string()) return v->get();
  if (const auto* v = node.as_integer()) return v->get();
  if (const auto* v = node.as_floating_point()) return v->get();
  if (const auto* v = node.as_boolean()) return v->get();
  return nullptr;  // dates and times: no rtsim key takes one, so the key reads as invalid
}
}  // namespace

nlohmann::json parse_config_text(const std::string& text, const std::string& file_name, bool toml) {
  if (toml) {
    try {
      return to_json(toml::parse(text, file_name));
    } catch (const toml::parse_error& e) {
      const auto& where = e.source().begin;
      throw InputError(file_name + ":" + std::to_string(where.line) + ":" +
                           std::to_string(where.column),
                       std::string(e.description()));
    }
  }
  DuplicateKeyFinder finder;
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(text, std::ref(finder));
  } catch (const nlohmann::json::exception& e) {
    // parse_error, and out_of_range for a number too large for a double (found by
    // fuzzing: it escaped as a non-InputError).
    throw InputError(file_name, std::string("JSON syntax error: ") + e.what());
  }
  if (!finder.duplicate.empty())
    throw InputError(file_name + ": key '" + finder.duplicate + "'",
                     "is defined twice in one object (JSON would keep the last silently)");
  return document;
}

nlohmann::json parse_config_file(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext != ".toml" && ext != ".json")
    throw InputError(path.string(), "expected a .toml or .json file");
  return parse_config_text(read_input_file(path, kMaxConfigFileBytes), path.string(), ext == ".toml");
}

ConfigTable::ConfigTable(const nlohmann::json& table, std::string file, std::string path)
    : table_(table), file_(std::move(file)), path_(std::move(path)) {
  if (!table_.is_object())
    throw InputError(file_, path_.empty() ? "the top level must be a table"
                                          : "key '" + path_ + "' must be a table");
}

std::string ConfigTable::where(const std::string& key) const {
  return file_ + ": key '" + (path_.empty() ? key : path_ + "." + key) + "'";
}

bool ConfigTable::has(const std::string& key) const { return table_.contains(key); }

const nlohmann::json* ConfigTable::value(const std::string& key) {
  used_.insert(key);
  auto it = table_.find(key);
  return it == table_.end() ? nullptr : &*it;
}

std::string ConfigTable::string(const std::string& key, const std::string& fallback) {
  const nlohmann::json* v = value(key);
  if (!v) return fallback;
  if (!v->is_string()) throw InputError(where(key), "must be a string");
  return v->get<std::string>();
}

std::string ConfigTable::string(const std::string& key) {
  if (!has(key)) throw InputError(where(key), "is required");
  return string(key, "");
}

double ConfigTable::number(const std::string& key, double fallback, double min, double max) {
  const nlohmann::json* v = value(key);
  if (!v) return fallback;
  if (!v->is_number()) throw InputError(where(key), "must be a number");
  const double d = v->get<double>();
  if (!std::isfinite(d) || d < min || d > max)
    throw InputError(where(key), "value " + v->dump() + " is out of range [" +
                                     nlohmann::json(min).dump() + ", " +
                                     nlohmann::json(max).dump() + "]");
  return d;
}

double ConfigTable::number(const std::string& key, double min, double max) {
  if (!has(key)) throw InputError(where(key), "is required");
  return number(key, 0.0, min, max);
}

int64_t ConfigTable::integer(const std::string& key, int64_t fallback, int64_t min, int64_t max) {
  const nlohmann::json* v = value(key);
  if (!v) return fallback;
  if (!v->is_number_integer()) throw InputError(where(key), "must be an integer");
  const int64_t i = v->get<int64_t>();
  if (i < min || i > max)
    throw InputError(where(key), "value " + std::to_string(i) + " is out of range [" +
                                     std::to_string(min) + ", " + std::to_string(max) + "]");
  return i;
}

bool ConfigTable::boolean(const std::string& key, bool fallback) {
  const nlohmann::json* v = value(key);
  if (!v) return fallback;
  if (!v->is_boolean()) throw InputError(where(key), "must be true or false");
  return v->get<bool>();
}

vec3 ConfigTable::vector3(const std::string& key, vec3 fallback) {
  const nlohmann::json* v = value(key);
  if (!v) return fallback;
  if (!v->is_array() || v->size() != 3) throw InputError(where(key), "must be an array of 3 numbers");
  vec3 out;
  for (int i = 0; i < 3; ++i) {
    if (!(*v)[i].is_number()) throw InputError(where(key), "must be an array of 3 numbers");
    out[i] = (*v)[i].get<float>();
    if (!std::isfinite(out[i])) throw InputError(where(key), "must be finite");
  }
  return out;
}

vec3 ConfigTable::vector3(const std::string& key) {
  if (!has(key)) throw InputError(where(key), "is required");
  return vector3(key, vec3(0.0f));
}

ConfigTable ConfigTable::table(const std::string& key) {
  static const nlohmann::json empty = nlohmann::json::object();
  const nlohmann::json* v = value(key);
  return ConfigTable(v ? *v : empty, file_, path_.empty() ? key : path_ + "." + key);
}

std::vector<ConfigTable> ConfigTable::array_of_tables(const std::string& key) {
  std::vector<ConfigTable> out;
  const nlohmann::json* v = value(key);
  if (!v) return out;
  if (!v->is_array()) throw InputError(where(key), "must be an array of tables");
  for (size_t i = 0; i < v->size(); ++i)
    out.emplace_back((*v)[i], file_,
                     (path_.empty() ? key : path_ + "." + key) + "[" + std::to_string(i) + "]");
  return out;
}

const nlohmann::json& ConfigTable::raw(const std::string& key) {
  static const nlohmann::json null_value;
  const nlohmann::json* v = value(key);
  return v ? *v : null_value;
}

void ConfigTable::finish() const {
  for (auto it = table_.begin(); it != table_.end(); ++it)
    if (!used_.count(it.key())) throw InputError(where(it.key()), "is unknown");
}

}  // namespace rtsim
