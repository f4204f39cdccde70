#pragma once
// Hardware configuration of the simulated accelerator: every parameter of the
// ray generation, TRV, IST and shading units, the caches, the DRAM and the
// fidelity-specific knobs, with a documented default, a range and a unit.
//
// One table (for_each_parameter) is the single source of truth: loading a TOML
// file, writing the resolved configuration as JSON and the documentation of
// model/presets/*.toml all walk it, so they cannot drift apart.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace rtsim::sim {

enum class Fidelity { Functional, Lt, Cycle };
const char* fidelity_name(Fidelity fidelity);        // "functional", "lt", "cycle"
Fidelity parse_fidelity(const std::string& name);    // throws InputError naming --fidelity

struct CacheConfig {
  uint32_t size_bytes = 16 * 1024;
  uint32_t line_bytes = 64;
  uint32_t associativity = 4;
  uint32_t hit_latency_cycles = 2;  // accelerator cycles from request to data on a hit
  uint32_t mshrs = 8;               // outstanding distinct missing lines
  uint32_t ports = 1;               // accesses accepted per cycle (ports or banks)
  uint32_t fill_latency_cycles = 1; // next level's data arrival to data at the requester
  uint32_t interleave = 1;          // an L2 slice: it holds every interleave-th line (not a key)
  uint32_t sets() const { return size_bytes / (line_bytes * associativity); }
};
// Field by field; a field added above must be added here (the size check says so).
inline bool operator==(const CacheConfig& a, const CacheConfig& b) {
  static_assert(sizeof(CacheConfig) == 8 * sizeof(uint32_t), "compare every CacheConfig field");
  return a.size_bytes == b.size_bytes && a.line_bytes == b.line_bytes && a.associativity == b.associativity &&
         a.hit_latency_cycles == b.hit_latency_cycles && a.mshrs == b.mshrs && a.ports == b.ports &&
         a.fill_latency_cycles == b.fill_latency_cycles && a.interleave == b.interleave;
}
inline bool operator!=(const CacheConfig& a, const CacheConfig& b) { return !(a == b); }

// DRAM timing is in DRAM clock cycles (tCK), as the datasheets and public DRAM
// simulators state it; the model converts to picoseconds with tck_ps. The values
// below are the lpddr4-3200 part (apply_dram_part lists every part's sources).
struct DramConfig {
  std::string part = "lpddr4-3200";  // preset the timings below start from
  std::string model = "rtsim";       // rtsim | dramsim3 (cycle level; dram_reference.h)
  uint32_t channels = 2;
  uint32_t ranks = 1;
  uint32_t bank_groups = 1;        // per rank; 1 for parts without bank groups (LPDDR4)
  uint32_t banks = 8;              // per rank, over all bank groups
  uint32_t row_bytes = 4096;       // bytes of one row in one channel (page size)
  uint32_t tck_ps = 625;           // DRAM clock period
  uint32_t tcl = 28;               // column read to first data (RL)
  uint32_t tcwl = 14;              // column write to first data (WL)
  uint32_t trcd = 29;              // activate to column read
  uint32_t trcd_write = 29;        // activate to column write (GDDR6 tRCDWR; else tRCD)
  uint32_t trp = 29;               // precharge to activate
  uint32_t tras = 68;              // activate to precharge (minimum row open time)
  uint32_t trrd_s = 16;            // activate to activate, other bank group
  uint32_t trrd_l = 16;            // activate to activate, same bank group
  uint32_t tfaw = 64;              // window holding at most four activates per rank
  uint32_t tccd_s = 8;             // column to column, other bank group (per burst)
  uint32_t tccd_l = 8;             // column to column, same bank group (per burst)
  uint32_t twtr_s = 16;            // end of write data to read, other bank group
  uint32_t twtr_l = 16;            // end of write data to read, same bank group
  uint32_t twr = 29;               // end of write data to precharge (write recovery)
  uint32_t trtp = 12;              // read to precharge
  uint32_t trtrs = 1;              // idle data-bus cycles when its direction or rank changes
  uint32_t trefi = 6246;           // all-bank refresh interval per rank (0: no refresh)
  uint32_t trfc = 448;             // all-bank refresh: rank blocked this long
  uint32_t burst_cycles = 8;       // tCK the data bus is busy for one burst
  uint32_t burst_bytes = 64;       // bytes one burst carries
  std::string page_policy = "timeout";  // open | closed | timeout
  uint32_t page_timeout = 64;      // tCK a row may stay idle under the timeout policy
  uint32_t queue_entries = 32;     // request queue per channel, reads and writes (FR-FCFS)
  double write_drain_high = 0.5;   // writes queued (fraction of the queue) that start a drain
  double write_drain_low = 0.25;   // a drain stops at this many writes if reads wait
  // Address bits above the access offset, most significant first.
  std::string address_mapping = "row:rank:bank:column:bankgroup:channel";
  // Energy per command of one channel, set by the part (apply_dram_part cites them).
  double activate_pj = 2400;      // ACT + its PRE
  double read_burst_pj = 2700;    // one burst of burst_bytes read
  double write_burst_pj = 2000;   // one burst written
  double refresh_pj = 44000;      // one all-bank REF of a rank
  double background_mw = 68.3;    // standby power of one channel, banks precharged (IDD2N)
  uint32_t banks_per_group() const { return banks / bank_groups; }
};

// Dynamic energy of the on-chip parts (energy.h). Cache accesses cost what a
// CACTI table gives for one instance's size (cache_access_pj), times sram_scale.
struct EnergyConfig {
  double sram_scale = 1.0;          // a further factor on cache energies (another SRAM design)
  uint32_t process_nm = 65;         // the node every on-chip energy is scaled to
  double vdd = 0;                   // its supply in volts; 0: the node's nominal
  double box_test_pj = 137;         // one ray-box slab test
  double triangle_test_pj = 721;    // one ray-triangle test
  double anyhit_test_pj = 173;      // one alpha test: UV interpolation, texel address, compare
  double xfm_pj = 367;              // one instance transform of a ray's origin and direction
  double noc_byte_pj = 4.8;         // one byte across the crossbar (one hop)
};
// Energy of one access to an SRAM cache of size_bytes (64-byte lines, one bank):
// SimTRaX's CACTI table (dkoptacs/simtrax samples/configs/dcacheparams.txt),
// interpolated in log2(size).
double cache_access_pj(uint64_t size_bytes);

// Stillmaker and Baas's energy scaling (Integration 58, 2017): the factor that takes a
// circuit's energy at from_nm (its nominal supply) to to_nm at vdd volts (0: nominal).
// Nodes: 65, 45, 32, 20, 16, 14, 10, 7.
std::vector<uint32_t> process_nodes();
double nominal_vdd(uint32_t nm);
double process_energy_factor(uint32_t from_nm, uint32_t to_nm, double vdd);

struct HardwareConfig {
  std::string preset = "mobile";
  uint32_t clock_mhz = 1000;  // accelerator clock; every *_cycles parameter counts it

  // The machine (machine.h): `cores` RT cores, each with its own ray generation,
  // trv_units TRV and ist_units IST units, shading and L1 caches, joined by a
  // crossbar to an L2 of l2_slices slices interleaved by line address.
  uint32_t cores = 1;
  // The per-unit cycle accounting (accounting.h): on, or off for speed - the
  // <unit>.<bucket>_cycles, utilisation and machine.<kind> roll-ups are then not
  // reported and the timeline cannot be drawn; nothing else changes.
  std::string accounting = "on";  // on | off
  bool accounted() const { return accounting == "on"; }
  std::string raygen_dispatch = "static";  // primary tiles to cores: static (round-robin) | dynamic
  uint32_t l2_slices = 1;
  uint32_t noc_latency_cycles = 0;  // crossbar traversal, one way
  uint32_t noc_flit_bytes = 0;      // bytes a crossbar port moves per cycle (0: ideal, unlimited)
  uint32_t noc_header_bytes = 8;    // address and command of every message

  // Ray generation
  double raygen_rays_per_cycle = 1.0;
  std::string raygen_order = "tiles";      // primary issue order: scanline | tiles | morton
  std::string raygen_tile = "8x8";         // tile size for raygen_order = tiles
  std::string raygen_secondary = "behind";  // secondary rays: behind their parent | after all primaries

  // Ray reordering between ray generation and TRV (ray_reorder.h); 0 rays: no unit.
  uint32_t reorder_batch_rays = 0;
  std::string reorder_key = "origin";  // none | origin | octant_origin | first_node
  uint32_t reorder_stage_cycles = 1;   // per compare stage of the batch's sort
  uint32_t reorder_entry_bytes = 48;   // one buffered ray: origin, direction, t range, ids, key

  // TRV
  uint32_t trv_units = 4;
  uint32_t trv_ray_slots = 16;        // rays in flight per unit (hide memory latency)
  uint32_t trv_stack_entries = 8;     // short stack on chip; deeper entries spill to memory
  uint32_t trv_stack_entry_bytes = 8; // node index + entry distance
  uint32_t trv_box_test_latency = 4;  // cycles from node data to the next decision
  double trv_nodes_per_cycle = 1.0;   // box-test pipeline passes per cycle per unit
  uint32_t trv_boxes_per_pass = 4;    // child boxes one pass tests; wider nodes take more passes
  // Pipeline passes a node of `boxes` child boxes takes (at least one).
  uint32_t trv_passes(uint32_t boxes) const {
    return boxes <= trv_boxes_per_pass ? 1 : (boxes + trv_boxes_per_pass - 1) / trv_boxes_per_pass;
  }
  // A TRV unit step's passes and latency (cycles): a node's box tests, or an
  // instance transform (instanced scenes), which issues into the same pipeline.
  uint32_t trv_step_passes(uint32_t boxes, bool transform) const {
    return transform ? xfm_passes : trv_passes(boxes);
  }
  uint32_t trv_step_latency(bool transform) const { return transform ? xfm_latency : trv_box_test_latency; }

  // IST
  uint32_t ist_units = 2;
  uint32_t ist_queue_entries = 16;    // leaf jobs waiting per unit (back-pressure to TRV)
  uint32_t ist_test_latency = 8;      // cycles per triangle test
  uint32_t ist_triangles_in_flight = 4;  // triangles of a leaf fetched together, then tested in order
  double ist_tests_per_cycle = 1.0;   // throughput per unit
  // The any-hit stage at the end of each IST unit's pipeline (alpha-tested scenes
  // only): interpolates the candidate's UVs, reads the texel through the unit's L1
  // texture cache and compares its alpha with the material's cutoff.
  uint32_t anyhit_test_latency = 4;   // cycles from the texel's arrival to the verdict
  uint32_t xfm_latency = 12;          // cycles from the instance record's arrival to the object-space ray
  uint32_t xfm_passes = 1;            // box-test pipeline passes one transform occupies in its TRV unit
  double anyhit_tests_per_cycle = 1.0;

  // Shading
  uint32_t shading_latency = 16;      // cycles per finished ray
  double shading_rays_per_cycle = 1.0;

  CacheConfig l1_node{16 * 1024, 64, 4, 2, 8};
  CacheConfig l1_triangle{16 * 1024, 64, 4, 2, 8};
  CacheConfig l1_texture{16 * 1024, 64, 4, 2, 8};  // per IST unit; built for alpha-tested scenes
  // Cores whose L1 caches differ from the rest: `[core.N]` tables of l1_node.* and
  // l1_triangle.* keys on top of the machine's values (line sizes stay the machine's).
  struct CoreCaches {
    CacheConfig l1_node, l1_triangle;
  };
  std::map<uint32_t, CoreCaches> core_caches;
  const CacheConfig& l1_node_of(uint32_t core) const {
    auto it = core_caches.find(core);
    return it == core_caches.end() ? l1_node : it->second.l1_node;
  }
  const CacheConfig& l1_triangle_of(uint32_t core) const {
    auto it = core_caches.find(core);
    return it == core_caches.end() ? l1_triangle : it->second.l1_triangle;
  }
  CacheConfig l2{512 * 1024, 64, 8, 20, 32, 2, 1};  // the whole L2; mshrs and ports per slice
  // One slice's geometry: l2 with size_bytes / l2_slices.
  CacheConfig l2_slice() const {
    CacheConfig c = l2;
    c.size_bytes = l2.size_bytes / std::max<uint32_t>(1, l2_slices);
    c.interleave = std::max<uint32_t>(1, l2_slices);
    return c;
  }
  DramConfig dram;
  EnergyConfig energy;

  // Memory image layout (builder/memory_image.h)
  std::string node_format = "bvh2-64";  // builder/node_format.h: bvh2-64 | bvh2-32 | bvh4-128 | ...
  std::string node_order = "depth-first";  // depth-first | breadth-first
  std::string triangle_storage = "indexed";  // indexed (via prim refs) | inline (in the leaf)
  std::string triangle_packing = "packed";   // packed | line (no record straddles an L1 line)
  uint32_t triangle_bytes = 36;

  // Loosely timed: the quantum keeper's global quantum. It sets only how often the
  // lt thread yields to the SystemC kernel, never a result.
  uint32_t lt_quantum_cycles = 1000;

  double clock_period_ps() const { return 1e6 / clock_mhz; }
  // The period in whole picoseconds: the grid every unit's timing is on.
  uint64_t cycle_ps() const { return uint64_t(std::llround(clock_period_ps())); }
};

// Kinds of parameter values the table knows.
struct ParameterInfo {
  std::string key;          // "trv.units", "dram.tcl", ...
  std::string unit;         // "cycles", "bytes", ...
  std::string description;
  // Exactly one of these is set.
  uint32_t* u32 = nullptr;
  double* f64 = nullptr;
  std::string* text = nullptr;
  double min = 0, max = 0;              // numeric range (inclusive)
  std::vector<std::string> choices;     // allowed strings (empty: any)
};
void for_each_parameter(HardwareConfig& config, const std::function<void(ParameterInfo&)>& visit);

std::vector<std::string> preset_names();  // "mobile", "desktop", "mobile-gpu", "desktop-gpu"
HardwareConfig preset(const std::string& name);  // throws InputError
// Where a preset's numbers come from (the head of model/presets/<name>.toml).
std::string preset_sources(const std::string& name);
// One DRAM part: its timings (tCK), shape and energy as DramConfig holds them, its
// data rate and channel width (which its burst must carry), and where the numbers
// come from. The rows are dram_parts(); apply_dram_part copies one into a DramConfig.
struct DramPart {
  const char* name;
  uint32_t data_rate_mtps, channel_bits;  // transfers per second per pin; data bits per channel
  uint32_t tck_ps, tcl, tcwl, trcd, trcd_write, trp, tras;
  uint32_t trrd_s, trrd_l, tfaw, tccd_s, tccd_l, twtr_s, twtr_l;
  uint32_t twr, trtp, trtrs, trefi, trfc;
  uint32_t burst_cycles, burst_bytes, bank_groups, banks, row_bytes;
  double activate_pj, read_burst_pj, write_burst_pj, refresh_pj, background_mw;
  const char* timing_source;
  const char* energy_source;
};
const std::vector<DramPart>& dram_parts();
std::vector<std::string> dram_part_names();  // "lpddr4-3200", "ddr4-2400", "gddr6", "lpddr5"
void apply_dram_part(DramConfig& dram, const std::string& part);  // throws InputError

// A preset name or a TOML file: `preset = "..."` (default "mobile") picks the base,
// `dram.part` the DRAM timings, then every other key overrides. Unknown keys,
// wrong types and out-of-range values throw InputError naming file and key.
HardwareConfig load_hardware_config(const std::string& preset_or_path);
HardwareConfig parse_hardware_config(const std::string& toml_text, const std::string& source_name);
// Cross-parameter checks (powers of two, line sizes, set counts, DRAM bank groups,
// refresh and write-drain limits); throws InputError naming the key.
void validate(const HardwareConfig& config);
// raygen.tile "WxH" -> (W, H); throws InputError naming raygen.tile.
std::pair<uint32_t, uint32_t> parse_tile(const std::string& text);
// The resolved configuration as a JSON object text, keys sorted.
std::string to_json(const HardwareConfig& config);
// A documented TOML listing of every parameter with its value (model/presets/*.toml).
std::string to_documented_toml(const HardwareConfig& config);

}  // namespace rtsim::sim
