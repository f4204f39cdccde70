#include <rtsim/model/sim/config.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace rtsim::sim {

const char* fidelity_name(Fidelity fidelity) {
  switch (fidelity) {
    case Fidelity::Functional: return "functional";
    case Fidelity::Lt: return "lt";
    case Fidelity::Cycle: return "cycle";
  }
  return "?";
}

Fidelity parse_fidelity(const std::string& name) {
  if (name == "functional") return Fidelity::Functional;
  if (name == "lt") return Fidelity::Lt;
  if (name == "cycle") return Fidelity::Cycle;
  throw InputError("--fidelity", "unknown level '" + name + "' (functional | lt | cycle)");
}

namespace {

ParameterInfo u32(const std::string& key, uint32_t& field, double min, double max,
                  const std::string& unit, const std::string& description) {
  ParameterInfo p;
  p.key = key, p.unit = unit, p.description = description, p.u32 = &field, p.min = min,
  p.max = max;
  return p;
}
ParameterInfo f64(const std::string& key, double& field, double min, double max,
                  const std::string& unit, const std::string& description) {
  ParameterInfo p;
  p.key = key, p.unit = unit, p.description = description, p.f64 = &field, p.min = min,
  p.max = max;
  return p;
}
ParameterInfo text(const std::string& key, std::string& field, std::vector<std::string> choices,
                   const std::string& description) {
  ParameterInfo p;
  p.key = key, p.description = description, p.text = &field, p.choices = std::move(choices);
  return p;
}

void cache_parameters(const std::string& prefix, CacheConfig& c, const std::string& what,
                      const std::function<void(ParameterInfo&)>& visit) {
  std::vector<ParameterInfo> list = {
      u32(prefix + ".size_bytes", c.size_bytes, 256, 1u << 30, "bytes", "capacity of " + what),
      u32(prefix + ".line_bytes", c.line_bytes, 16, 4096, "bytes", "line size (power of two)"),
      u32(prefix + ".associativity", c.associativity, 1, 64, "ways", "ways per set (LRU)"),
      u32(prefix + ".hit_latency_cycles", c.hit_latency_cycles, 1, 10000, "cycles",
          "request to data on a hit"),
      u32(prefix + ".mshrs", c.mshrs, 1, 4096, "entries",
          "distinct missing lines outstanding; requests to a missing line merge"),
  };
  for (auto& p : list) visit(p);
}

}  // namespace

void for_each_parameter(HardwareConfig& c, const std::function<void(ParameterInfo&)>& visit) {
  std::vector<ParameterInfo> list = {
      text("preset", c.preset, preset_names(), "base preset the other keys override"),
      u32("clock_mhz", c.clock_mhz, 1, 10000, "MHz", "accelerator clock; all *_cycles count it"),
      f64("raygen.rays_per_cycle", c.raygen_rays_per_cycle, 0.001, 64, "rays/cycle",
          "rate at which ray generation issues rays"),
      u32("trv.units", c.trv_units, 1, 256, "units", "traversal units"),
      u32("trv.ray_slots", c.trv_ray_slots, 1, 4096, "rays",
          "rays in flight per TRV unit (hide memory latency)"),
      u32("trv.stack_entries", c.trv_stack_entries, 1, 256, "entries",
          "on-chip short stack per ray; deeper entries spill to memory (kind 'other')"),
      u32("trv.stack_entry_bytes", c.trv_stack_entry_bytes, 4, 64, "bytes",
          "bytes one spilled stack entry occupies in memory"),
      u32("trv.box_test_latency", c.trv_box_test_latency, 1, 10000, "cycles",
          "node data arrival to the traversal decision"),
      f64("trv.nodes_per_cycle", c.trv_nodes_per_cycle, 0.001, 64, "nodes/cycle",
          "box-test pipeline throughput per unit"),
      u32("ist.units", c.ist_units, 1, 256, "units", "intersection units"),
      u32("ist.queue_entries", c.ist_queue_entries, 1, 4096, "jobs",
          "leaf jobs waiting per IST unit; a full queue stalls TRV"),
      u32("ist.test_latency", c.ist_test_latency, 1, 10000, "cycles",
          "triangle data arrival to the test result"),
      f64("ist.tests_per_cycle", c.ist_tests_per_cycle, 0.001, 64, "tests/cycle",
          "triangle-test pipeline throughput per unit"),
      u32("shading.latency", c.shading_latency, 1, 100000, "cycles",
          "finished ray to its shading result and spawned rays"),
      f64("shading.rays_per_cycle", c.shading_rays_per_cycle, 0.001, 64, "rays/cycle",
          "shading throughput"),
      text("memory.node_layout", c.node_layout, {"bvh2-64", "single-32"},
           "BVH node format in memory (64-byte two-box node or 32-byte one-box node)"),
      u32("memory.triangle_bytes", c.triangle_bytes, 36, 256, "bytes",
          "bytes one triangle occupies in memory"),
      u32("lt.quantum_cycles", c.lt_quantum_cycles, 1, 100000000, "cycles",
          "global quantum of the loosely timed model (temporal decoupling)"),
  };
  for (auto& p : list) visit(p);
  cache_parameters("l1_node", c.l1_node, "each TRV unit's L1 node cache", visit);
  cache_parameters("l1_triangle", c.l1_triangle, "each IST unit's L1 triangle cache", visit);
  cache_parameters("l2", c.l2, "the shared L2", visit);
  DramConfig& d = c.dram;
  std::vector<ParameterInfo> dram = {
      text("dram.part", d.part, dram_part_names(), "DRAM part the timings start from"),
      u32("dram.channels", d.channels, 1, 64, "channels", "independent channels (power of two)"),
      u32("dram.ranks", d.ranks, 1, 16, "ranks", "ranks per channel (power of two)"),
      u32("dram.banks", d.banks, 1, 64, "banks", "banks per rank (power of two)"),
      u32("dram.row_bytes", d.row_bytes, 64, 1u << 20, "bytes", "row (page) size per channel"),
      u32("dram.tck_ps", d.tck_ps, 100, 100000, "ps", "DRAM clock period"),
      u32("dram.tcl", d.tcl, 1, 1000, "tCK", "read command to first data"),
      u32("dram.trcd", d.trcd, 1, 1000, "tCK", "activate to read"),
      u32("dram.trp", d.trp, 1, 1000, "tCK", "precharge to activate"),
      u32("dram.tras", d.tras, 1, 1000, "tCK", "activate to precharge"),
      u32("dram.burst_cycles", d.burst_cycles, 1, 256, "tCK", "data bus busy per burst"),
      u32("dram.burst_bytes", d.burst_bytes, 4, 4096, "bytes", "bytes per burst"),
      u32("dram.queue_entries", d.queue_entries, 1, 4096, "requests",
          "request queue per channel (FR-FCFS); a full queue back-pressures L2"),
      text("dram.address_mapping", d.address_mapping, {},
           "fields row, rank, bank, column, channel from most to least significant, ':'-separated"),
  };
  for (auto& p : dram) visit(p);
}

std::vector<std::string> dram_part_names() { return {"lpddr4-3200", "ddr4-2400", "gddr6"}; }

void apply_dram_part(DramConfig& d, const std::string& part) {
  // Timings in tCK as the public DRAM simulators configure these parts:
  // - lpddr4-3200: JESD209-4 speed bin as in Ramulator's LPDDR4_3200 preset: tCK 0.625 ns,
  //   RL 28, tRCD 29 (18 ns), tRPpb 29 (18 ns), tRAS 68 (42 ns), BL16 = 8 tCK. Channel of
  //   32 data bits (two x16 dies in lockstep) so a 64-byte line is one burst.
  // - ddr4-2400: DRAMsim3 DDR4_8Gb_x8_2400.ini: tCK 0.83 ns (833 ps), CL 16, tRCD 16,
  //   tRP 16, tRAS 39, BL8 = 4 tCK on a 64-bit DIMM channel (64 B per burst), 16 banks
  //   (4 groups x 4), 8 KiB rows.
  // - gddr6: DRAMsim3 GDDR6_8Gb_x16.ini: tCK 0.66 ns, CL 24, tRCDRD 24, tRP 15, tRAS 32,
  //   BL16 over a x16 channel = 32 B per burst, bursts of BL/4 = 4 tCK (quad data rate),
  //   16 banks, 2 KiB rows.
  if (part == "lpddr4-3200") {
    d.part = part, d.tck_ps = 625, d.tcl = 28, d.trcd = 29, d.trp = 29, d.tras = 68;
    d.burst_cycles = 8, d.burst_bytes = 64, d.banks = 8, d.row_bytes = 2048;
  } else if (part == "ddr4-2400") {
    d.part = part, d.tck_ps = 833, d.tcl = 16, d.trcd = 16, d.trp = 16, d.tras = 39;
    d.burst_cycles = 4, d.burst_bytes = 64, d.banks = 16, d.row_bytes = 8192;
  } else if (part == "gddr6") {
    d.part = part, d.tck_ps = 660, d.tcl = 24, d.trcd = 24, d.trp = 15, d.tras = 32;
    d.burst_cycles = 4, d.burst_bytes = 32, d.banks = 16, d.row_bytes = 2048;
  } else {
    std::string all;
    for (auto& n : dram_part_names()) all += (all.empty() ? "" : " | ") + n;
    throw InputError("dram.part", "unknown DRAM part '" + part + "' (" + all + ")");
  }
}

std::vector<std::string> preset_names() { return {"mobile", "desktop"}; }

HardwareConfig preset(const std::string& name) {
  HardwareConfig c;
  if (name == "mobile") {
    // The patent's target class: a small accelerator in a phone SoC on LPDDR4.
    c.preset = name;
    apply_dram_part(c.dram, "lpddr4-3200");
    c.dram.channels = 2;
  } else if (name == "desktop") {
    c.preset = name;
    c.clock_mhz = 1500;
    c.trv_units = 8, c.trv_ray_slots = 32, c.trv_stack_entries = 16;
    c.ist_units = 4;
    c.l1_node = {32 * 1024, 64, 4, 2, 16};
    c.l1_triangle = {32 * 1024, 64, 4, 2, 16};
    c.l2 = {2 * 1024 * 1024, 64, 16, 30, 64};
    apply_dram_part(c.dram, "ddr4-2400");
    c.dram.channels = 2;
  } else {
    throw InputError("preset", "unknown preset '" + name + "' (mobile | desktop)");
  }
  return c;
}

namespace {

bool is_pow2(uint64_t v) { return v && !(v & (v - 1)); }

void check_cache(const std::string& key, const CacheConfig& c) {
  if (!is_pow2(c.line_bytes)) throw InputError(key + ".line_bytes", "must be a power of two");
  if (c.size_bytes % (c.line_bytes * c.associativity) != 0 || c.sets() == 0)
    throw InputError(key + ".size_bytes",
                     "must be a multiple of line_bytes x associativity (" +
                         std::to_string(c.line_bytes * c.associativity) + ")");
  if (!is_pow2(c.sets()))
    throw InputError(key + ".size_bytes", "set count " + std::to_string(c.sets()) +
                                             " must be a power of two");
}

}  // namespace

void validate(const HardwareConfig& c) {
  check_cache("l1_node", c.l1_node);
  check_cache("l1_triangle", c.l1_triangle);
  check_cache("l2", c.l2);
  if (c.l1_node.line_bytes > c.l2.line_bytes)
    throw InputError("l1_node.line_bytes", "must not exceed l2.line_bytes");
  if (c.l1_triangle.line_bytes > c.l2.line_bytes)
    throw InputError("l1_triangle.line_bytes", "must not exceed l2.line_bytes");
  const DramConfig& d = c.dram;
  if (!is_pow2(d.channels)) throw InputError("dram.channels", "must be a power of two");
  if (!is_pow2(d.ranks)) throw InputError("dram.ranks", "must be a power of two");
  if (!is_pow2(d.banks)) throw InputError("dram.banks", "must be a power of two");
  if (!is_pow2(d.row_bytes)) throw InputError("dram.row_bytes", "must be a power of two");
  if (d.row_bytes < c.l2.line_bytes)
    throw InputError("dram.row_bytes", "must hold at least one l2 line");
  // The mapping must name each field exactly once.
  std::set<std::string> seen;
  std::stringstream in(d.address_mapping);
  std::string field;
  while (std::getline(in, field, ':')) {
    if (field != "row" && field != "rank" && field != "bank" && field != "column" &&
        field != "channel")
      throw InputError("dram.address_mapping", "unknown field '" + field + "'");
    if (!seen.insert(field).second)
      throw InputError("dram.address_mapping", "field '" + field + "' appears twice");
  }
  if (seen.size() != 5)
    throw InputError("dram.address_mapping",
                     "must name row, rank, bank, column and channel once each");
}

namespace {

void set_from_toml(ParameterInfo& p, const toml::node& node, const std::string& where) {
  const std::string key = where + p.key;
  if (p.text) {
    auto v = node.value<std::string>();
    if (!v) throw InputError(key, "must be a string");
    if (!p.choices.empty() &&
        std::find(p.choices.begin(), p.choices.end(), *v) == p.choices.end()) {
      std::string all;
      for (auto& n : p.choices) all += (all.empty() ? "" : " | ") + n;
      throw InputError(key, "'" + *v + "' is not one of " + all);
    }
    *p.text = *v;
    return;
  }
  double value;
  if (auto i = node.value_exact<int64_t>()) {
    value = double(*i);
  } else if (auto f = node.value_exact<double>()) {
    if (p.u32) throw InputError(key, "must be an integer");
    value = *f;
  } else {
    throw InputError(key, "must be a number");
  }
  if (!std::isfinite(value) || value < p.min || value > p.max) {
    std::ostringstream msg;
    msg << "value " << value << " out of range [" << p.min << ", " << p.max << "]";
    throw InputError(key, msg.str());
  }
  if (p.u32) *p.u32 = uint32_t(value);
  else *p.f64 = value;
}

// Every leaf of the TOML tree as "a.b.c" -> node.
void flatten(const toml::table& table, const std::string& prefix,
             std::vector<std::pair<std::string, const toml::node*>>& out) {
  for (auto&& [k, v] : table) {
    const std::string key = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    // An empty table is a leaf too: `[clock_mhz]` in place of `clock_mhz = 800`
    // must be refused by the key's type check, not vanish as a table with no keys.
    if (auto* sub = v.as_table(); sub && !sub->empty()) flatten(*sub, key, out);
    else out.emplace_back(key, &v);
  }
}

}  // namespace

HardwareConfig parse_hardware_config(const std::string& toml_text, const std::string& source) {
  toml::table table;
  try {
    table = toml::parse(toml_text, source);
  } catch (const toml::parse_error& e) {
    std::ostringstream msg;
    msg << e.description() << " (line " << e.source().begin.line << ")";
    throw InputError(source, msg.str());
  }
  const std::string where = source + ": ";
  std::vector<std::pair<std::string, const toml::node*>> leaves;
  flatten(table, "", leaves);

  // Base preset, then the DRAM part, then every other key.
  HardwareConfig config = preset("mobile");
  if (auto* node = table.get("preset")) {
    auto name = node->value<std::string>();
    if (!name) throw InputError(where + "preset", "must be a string");
    try {
      config = preset(*name);
    } catch (const InputError& e) {
      throw InputError(where + e.what());
    }
  }
  if (auto* dram = table.get_as<toml::table>("dram"); dram && dram->get("part")) {
    auto part = dram->get("part")->value<std::string>();
    if (!part) throw InputError(where + "dram.part", "must be a string");
    try {
      apply_dram_part(config.dram, *part);
    } catch (const InputError& e) {
      throw InputError(where + e.what());
    }
  }
  std::map<std::string, ParameterInfo> params;
  for_each_parameter(config, [&](ParameterInfo& p) { params.emplace(p.key, p); });
  for (auto& [key, node] : leaves) {
    auto it = params.find(key);
    if (it == params.end() && node->is_table()) {
      // An empty section ([l2] with no keys) is harmless; an empty table that is
      // no section at all is as unknown as any other key.
      auto section = params.lower_bound(key + ".");
      if (section != params.end() && section->first.rfind(key + ".", 0) == 0) continue;
    }
    if (it == params.end()) throw InputError(where + key, "unknown key");
    set_from_toml(it->second, *node, where);
  }
  try {
    validate(config);
  } catch (const InputError& e) {
    throw InputError(where + e.what());
  }
  return config;
}

HardwareConfig load_hardware_config(const std::string& preset_or_path) {
  for (auto& name : preset_names())
    if (name == preset_or_path) {
      HardwareConfig c = preset(name);
      validate(c);
      return c;
    }
  if (!path_exists(preset_or_path))
    throw InputError(preset_or_path, "neither a preset (mobile | desktop) nor a file");
  // Bounded, and a folder or a FIFO is refused (a folder used to read as empty: defaults).
  return parse_hardware_config(read_input_file(preset_or_path, kMaxConfigFileBytes), preset_or_path);
}

std::string to_json(const HardwareConfig& config_in) {
  HardwareConfig config = config_in;
  nlohmann::json out = nlohmann::json::object();
  for_each_parameter(config, [&](ParameterInfo& p) {
    nlohmann::json* at = &out;
    std::stringstream in(p.key);
    std::string part, last;
    std::vector<std::string> parts;
    while (std::getline(in, part, '.')) parts.push_back(part);
    for (size_t i = 0; i + 1 < parts.size(); ++i) at = &(*at)[parts[i]];
    nlohmann::json& leaf = (*at)[parts.back()];
    if (p.text) leaf = *p.text;
    else if (p.u32) leaf = *p.u32;
    else leaf = *p.f64;
  });
  return out.dump(2);
}

std::string to_documented_toml(const HardwareConfig& config_in) {
  HardwareConfig config = config_in;
  std::ostringstream out;
  std::string section;
  for_each_parameter(config, [&](ParameterInfo& p) {
    const auto dot = p.key.find('.');
    const std::string sec = dot == std::string::npos ? "" : p.key.substr(0, dot);
    const std::string name = dot == std::string::npos ? p.key : p.key.substr(dot + 1);
    if (sec != section) {
      out << "\n[" << sec << "]\n";
      section = sec;
    }
    out << "# " << p.description;
    if (!p.unit.empty()) out << " [" << p.unit << "]";
    if (p.text && !p.choices.empty()) {
      out << " (";
      for (size_t i = 0; i < p.choices.size(); ++i) out << (i ? " | " : "") << p.choices[i];
      out << ")";
    } else if (!p.text) {
      out << " (" << p.min << " .. " << p.max << ")";
    }
    out << "\n" << name << " = ";
    if (p.text) out << '"' << *p.text << '"';
    else if (p.u32) out << *p.u32;
    else out << nlohmann::json(*p.f64).dump();
    out << "\n";
  });
  return out.str();
}

}  // namespace rtsim::sim
