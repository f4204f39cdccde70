#include <rtsim/model/sim/stats.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace rtsim::sim {

void StatsRegistry::set(const std::string& path, uint64_t value, const std::string& unit,
                        const std::string& description) {
  StatValue& v = values_[path];
  v.integer = true, v.count = value, v.unit = unit, v.description = description;
}

void StatsRegistry::set_real(const std::string& path, double value, const std::string& unit,
                             const std::string& description) {
  StatValue& v = values_[path];
  // JSON has no NaN/inf: an undefined ratio (0/0) is written as 0 and says so.
  v.integer = false, v.real = std::isfinite(value) ? value : 0.0, v.unit = unit;
  v.description = description;
}

const StatValue& StatsRegistry::at(const std::string& path) const {
  auto it = values_.find(path);
  if (it == values_.end()) throw std::out_of_range("no statistic '" + path + "'");
  return it->second;
}

double StatsRegistry::number(const std::string& path) const {
  const StatValue& v = at(path);
  return v.integer ? double(v.count) : v.real;
}

std::string StatsRegistry::to_json(int indent) const {
  nlohmann::json root = nlohmann::json::object();  // std::map inside: sorted keys
  for (const auto& [path, v] : values_) {
    nlohmann::json* at = &root;
    std::stringstream in(path);
    std::string part;
    std::vector<std::string> parts;
    while (std::getline(in, part, '.')) parts.push_back(part);
    for (size_t i = 0; i + 1 < parts.size(); ++i) at = &(*at)[parts[i]];
    nlohmann::json leaf = nlohmann::json::object();
    if (v.integer) leaf["value"] = v.count;
    else leaf["value"] = v.real;
    leaf["unit"] = v.unit;
    leaf["description"] = v.description;
    (*at)[parts.back()] = std::move(leaf);
  }
  return root.dump(indent) + "\n";
}

}  // namespace rtsim::sim
