#pragma once
// A hierarchical statistics registry: every value has a dotted path
// ("trv.unit0.busy_cycles"), a unit and a description, and is written as nested
// JSON with sorted keys so that the same run gives byte-identical output.
#include <cstdint>
#include <map>
#include <string>

namespace rtsim::sim {

struct StatValue {
  bool integer = true;
  uint64_t count = 0;
  double real = 0;
  std::string unit;
  std::string description;
};

class StatsRegistry {
 public:
  void set(const std::string& path, uint64_t value, const std::string& unit,
           const std::string& description);
  void set_real(const std::string& path, double value, const std::string& unit,
                const std::string& description);
  bool contains(const std::string& path) const { return values_.count(path) != 0; }
  const StatValue& at(const std::string& path) const;  // throws std::out_of_range
  double number(const std::string& path) const;       // integer or real as double
  const std::map<std::string, StatValue>& values() const { return values_; }
  // {"trv": {"unit0": {"busy_cycles": {"value": 1, "unit": "cycles", "description": "..."}}}}
  std::string to_json(int indent = 2) const;

 private:
  std::map<std::string, StatValue> values_;
};

}  // namespace rtsim::sim
