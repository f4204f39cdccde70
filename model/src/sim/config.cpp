#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/machine.h>
#include <rtsim/builder/node_format.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/numbers.h>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
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
std::vector<std::string> node_format_list() {
  std::vector<std::string> names;
  for (const NodeFormat& f : node_formats()) names.push_back(f.name);
  return names;
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
          "distinct missing lines outstanding; reads of a missing line merge (cycle level; "
          "lt has no MSHR limit)"),
      u32(prefix + ".ports", c.ports, 1, 64, "accesses/cycle",
          "requests accepted per cycle (ports or banks); more wait for the next free slot"),
      u32(prefix + ".fill_latency_cycles", c.fill_latency_cycles, 0, 10000, "cycles",
          "next level's data arrival to the line installed and the data at the requester"),
  };
  for (auto& p : list) visit(p);
}

}  // namespace

void for_each_parameter(HardwareConfig& c, const std::function<void(ParameterInfo&)>& visit) {
  std::vector<ParameterInfo> list = {
      text("preset", c.preset, preset_names(), "base preset the other keys override"),
      u32("clock_mhz", c.clock_mhz, 1, 10000, "MHz", "accelerator clock; all *_cycles count it"),
      u32("cores", c.cores, 1, 256, "cores",
          "RT cores; each has its own ray generation, trv.units TRV units, ist.units IST units, "
          "shading and L1 caches (every per-unit key below is per core)"),
      f64("raygen.rays_per_cycle", c.raygen_rays_per_cycle, 0.001, 64, "rays/cycle",
          "rate at which each core's ray generation issues rays"),
      text("raygen.order", c.raygen_order, {"scanline", "tiles", "morton"},
           "issue order of primary rays: row by row, tile by tile (raygen.tile, rows within a "
           "tile), or along a Morton curve"),
      text("raygen.tile", c.raygen_tile, {},
           "tile size WxH: the issue order within a tile for raygen.order = tiles, and the "
           "pixels handed to a core at a time (raygen.dispatch)"),
      text("raygen.secondary", c.raygen_secondary, {"behind", "after"},
           "secondary rays (AO, shadow, mirror) go right behind their parent, ahead of new "
           "primary rays, or after all primary rays"),
      text("raygen.dispatch", c.raygen_dispatch, {"static", "dynamic"},
           "how primary rays reach the cores, a raygen.tile of pixels at a time: static "
           "(tile i to core i mod cores) or dynamic (a core that runs out takes the next tile); "
           "a ray's secondary rays stay on its core"),
      u32("reorder.batch_rays", c.reorder_batch_rays, 0, 4096, "rays",
          "the ray-reordering unit between ray generation and TRV (one per core) holds up to this "
          "many rays, primary and secondary, and releases them sorted by reorder.key; 0: no unit"),
      text("reorder.key", c.reorder_key, {"none", "origin", "octant_origin", "first_node"},
           "the reordering unit's sort key: none (arrival order), the origin's Morton code on a "
           "1024^3 grid over the tree's box, the direction octant then that code, or the node the "
           "ray enters after the root (the unit box-tests the root's children)"),
      u32("reorder.stage_cycles", c.reorder_stage_cycles, 0, 1000, "cycles",
          "cycles per compare stage of the unit's sort: a batch of B rays leaves after the depth "
          "of Batcher's bitonic network, k (k + 1) / 2 stages for k = ceil(log2 B) (36 for 256 rays)"),
      u32("reorder.entry_bytes", c.reorder_entry_bytes, 16, 256, "bytes",
          "one buffered ray (origin, direction, t range, ids, key): the buffer is batch_rays x "
          "this, and its access energy is the cache table's for that size"),
      u32("trv.units", c.trv_units, 1, 256, "units", "traversal units per core"),
      u32("trv.ray_slots", c.trv_ray_slots, 1, 4096, "rays",
          "rays in flight per TRV unit (hide memory latency)"),
      u32("trv.stack_entries", c.trv_stack_entries, 1, 256, "entries",
          "on-chip short stack per ray; deeper entries spill to memory (byte kind 'stack')"),
      u32("trv.stack_entry_bytes", c.trv_stack_entry_bytes, 4, 64, "bytes",
          "bytes one spilled stack entry occupies in memory"),
      u32("trv.box_test_latency", c.trv_box_test_latency, 1, 10000, "cycles",
          "node data arrival to the traversal decision"),
      f64("trv.nodes_per_cycle", c.trv_nodes_per_cycle, 0.001, 64, "passes/cycle",
          "box-test pipeline throughput per unit: passes per cycle (a node of up to "
          "trv.boxes_per_pass children is one pass)"),
      u32("trv.boxes_per_pass", c.trv_boxes_per_pass, 1, 16, "boxes",
          "child boxes one pipeline pass tests; a node with more children takes "
          "ceil(children / boxes_per_pass) passes, each adding 1 / nodes_per_cycle to its latency"),
      u32("ist.units", c.ist_units, 1, 256, "units", "intersection units per core"),
      u32("ist.queue_entries", c.ist_queue_entries, 1, 4096, "jobs",
          "leaf jobs waiting per IST unit; a full queue stalls TRV"),
      u32("ist.test_latency", c.ist_test_latency, 1, 10000, "cycles",
          "triangle data arrival to the test result"),
      u32("ist.triangles_in_flight", c.ist_triangles_in_flight, 1, 64, "triangles",
          "triangles of a leaf fetched together (their fetches overlap), then tested in order; "
          "an any-hit ray may fetch up to this many - 1 it does not test"),
      f64("ist.tests_per_cycle", c.ist_tests_per_cycle, 0.001, 64, "tests/cycle",
          "triangle-test pipeline throughput per unit"),
      u32("anyhit.test_latency", c.anyhit_test_latency, 1, 10000, "cycles",
          "the any-hit stage of each IST unit (built only for scenes with alpha-tested "
          "materials): the candidate hit's texel arrival to the alpha test's verdict"),
      f64("anyhit.tests_per_cycle", c.anyhit_tests_per_cycle, 0.001, 64, "tests/cycle",
          "alpha tests the any-hit stage starts per cycle (its UV and texel reads go through "
          "l1_texture)"),
      u32("xfm.latency", c.xfm_latency, 1, 10000, "cycles",
          "the instance transform of each TRV unit (instanced scenes): the instance record's arrival "
          "to the object-space ray; a multiply and a two-level add tree at the 4-cycle FP latency "
          "of trv.box_test_latency's default"),
      u32("xfm.passes", c.xfm_passes, 1, 64, "passes",
          "passes of the TRV unit's box-test pipeline one instance transform occupies (it issues "
          "into that pipeline at trv.nodes_per_cycle, so it counts in machine.trv_passes)"),
      u32("shading.latency", c.shading_latency, 1, 100000, "cycles",
          "finished ray to its shading result and spawned rays"),
      f64("shading.rays_per_cycle", c.shading_rays_per_cycle, 0.001, 64, "rays/cycle",
          "shading throughput per core"),
      text("memory.node_format", c.node_format, node_format_list(),
           "BVH node record format (docs/node-formats.md): children per node, bytes, box "
           "encoding; the tree is built (collapsed) for its width and leaf capacity"),
      text("memory.node_order", c.node_order, {"depth-first", "breadth-first"},
           "order of node records and of leaf data in memory"),
      text("memory.triangle_storage", c.triangle_storage, {"indexed", "inline"},
           "indexed: a leaf's prim-ref list holds its triangles' record indices (one record per "
           "triangle); inline: each leaf's triangle records stored in the leaf, no prim refs "
           "(triangles in several leaves, as SBVH makes, are stored once per leaf)"),
      text("memory.triangle_packing", c.triangle_packing, {"packed", "line"},
           "packed: records at a stride of triangle_bytes; line: a record that would straddle an "
           "L1 triangle-cache line starts at the next line"),
      u32("memory.triangle_bytes", c.triangle_bytes, 36, 256, "bytes",
          "bytes of one triangle record (36: three float3 vertices; more with padding or "
          "precomputed data)"),
      u32("lt.quantum_cycles", c.lt_quantum_cycles, 1, 100000000, "cycles",
          "global quantum of the loosely timed model: how often its thread yields to the SystemC "
          "kernel (temporal decoupling); results do not depend on it"),
  };
  for (auto& p : list) visit(p);
  cache_parameters("l1_node", c.l1_node, "each TRV unit's L1 node cache", visit);
  cache_parameters("l1_triangle", c.l1_triangle, "each IST unit's L1 triangle cache", visit);
  cache_parameters("l1_texture", c.l1_texture,
                   "each IST unit's L1 texture cache, which its any-hit stage reads UVs and texels "
                   "through (built only for scenes with alpha-tested materials)",
                   visit);
  cache_parameters("l2", c.l2, "the shared L2 (all slices)", visit);
  std::vector<ParameterInfo> machine = {
      u32("l2.slices", c.l2_slices, 1, 64, "slices",
          "L2 slices, lines interleaved across them by address (line index mod slices); "
          "l2.size_bytes is the whole L2, l2.mshrs and l2.ports are per slice"),
      u32("noc.latency_cycles", c.noc_latency_cycles, 0, 10000, "cycles",
          "crossbar between the cores' L1s and the L2 slices: cycles one way"),
      u32("noc.flit_bytes", c.noc_flit_bytes, 0, 4096, "bytes/cycle",
          "bytes one crossbar port (each core's and each slice's, each way) moves per cycle; "
          "0: unlimited (no serialisation, no queueing)"),
      u32("noc.header_bytes", c.noc_header_bytes, 0, 256, "bytes",
          "address and command every crossbar message carries besides its data"),
  };
  for (auto& p : machine) visit(p);
  DramConfig& d = c.dram;
  std::vector<ParameterInfo> dram = {
      text("dram.part", d.part, dram_part_names(), "DRAM part the timings start from"),
      text("dram.model", d.model, {"rtsim", "dramsim3"},
           "cycle level: rtsim (ours) or dramsim3 (DRAMsim3 configured from these keys; needs an "
           "rtsim configured with -DRTSIM_DRAMSIM3=DIR)"),
      u32("dram.channels", d.channels, 1, 64, "channels",
          "independent channels (any count: the address map's channel field is a mixed-radix digit)"),
      u32("dram.ranks", d.ranks, 1, 16, "ranks", "ranks per channel (power of two)"),
      u32("dram.bank_groups", d.bank_groups, 1, 16, "groups",
          "bank groups per rank (power of two dividing banks; 1: no bank groups, the _l "
          "timings apply between any two banks)"),
      u32("dram.banks", d.banks, 1, 64, "banks", "banks per rank over all groups (power of two)"),
      u32("dram.row_bytes", d.row_bytes, 64, 1u << 20, "bytes",
          "row (page) of one bank across the channel's devices"),
      u32("dram.tck_ps", d.tck_ps, 100, 100000, "ps", "DRAM clock period"),
      u32("dram.tcl", d.tcl, 1, 1000, "tCK", "read command to first data (RL)"),
      u32("dram.tcwl", d.tcwl, 1, 1000, "tCK", "write command to first data (WL)"),
      u32("dram.trcd", d.trcd, 1, 1000, "tCK", "activate to read"),
      u32("dram.trcd_write", d.trcd_write, 1, 1000, "tCK",
          "activate to write (GDDR6 tRCDWR; equal to trcd elsewhere)"),
      u32("dram.trp", d.trp, 1, 1000, "tCK", "precharge to activate"),
      u32("dram.tras", d.tras, 1, 1000, "tCK", "activate to precharge"),
      u32("dram.trrd_s", d.trrd_s, 1, 1000, "tCK", "activate to activate, other bank group"),
      u32("dram.trrd_l", d.trrd_l, 1, 1000, "tCK", "activate to activate, same bank group"),
      u32("dram.tfaw", d.tfaw, 1, 10000, "tCK",
          "rolling window in which a rank accepts at most four activates"),
      u32("dram.tccd_s", d.tccd_s, 1, 1000, "tCK",
          "column to column per burst, other bank group of the rank"),
      u32("dram.tccd_l", d.tccd_l, 1, 1000, "tCK",
          "column to column per burst, same bank group"),
      u32("dram.twtr_s", d.twtr_s, 1, 1000, "tCK",
          "end of write data to a read command, other bank group"),
      u32("dram.twtr_l", d.twtr_l, 1, 1000, "tCK",
          "end of write data to a read command, same bank group"),
      u32("dram.twr", d.twr, 1, 1000, "tCK", "end of write data to precharge (write recovery)"),
      u32("dram.trtp", d.trtp, 1, 1000, "tCK", "read command (its last burst) to precharge"),
      u32("dram.trtrs", d.trtrs, 0, 1000, "tCK",
          "idle data-bus cycles between bursts of different direction or rank; read to write "
          "command = tcl + tBURST - tcwl + trtrs"),
      u32("dram.trefi", d.trefi, 0, 1000000, "tCK",
          "all-bank refresh interval per rank (0: no refresh)"),
      u32("dram.trfc", d.trfc, 1, 100000, "tCK",
          "all-bank refresh time: the rank's banks stay precharged and blocked"),
      u32("dram.burst_cycles", d.burst_cycles, 1, 256, "tCK", "data bus busy per burst"),
      u32("dram.burst_bytes", d.burst_bytes, 4, 4096, "bytes", "bytes per burst"),
      text("dram.page_policy", d.page_policy, {"open", "closed", "timeout"},
           "open: rows stay open until a conflict; closed: precharge after the last queued hit; "
           "timeout: precharge rows idle page_timeout. Default timeout, usual for LPDDR/DDR "
           "controllers under scattered reads: lines fetched together still hit, a later access "
           "finds the bank closed (tRCD) instead of conflicting (tRP + tRCD)"),
      u32("dram.page_timeout", d.page_timeout, 1, 1000000, "tCK",
          "idle time after a row's last column command until the timeout policy closes it"),
      u32("dram.queue_entries", d.queue_entries, 1, 4096, "requests",
          "request queue per channel, reads and writes (FR-FCFS); a full queue back-pressures L2"),
      f64("dram.write_drain_high", d.write_drain_high, 0.01, 1, "ratio",
          "writes queued, as a fraction of queue_entries, that switch the channel to draining "
          "writes (reads go first otherwise; writes also drain when no read waits)"),
      f64("dram.write_drain_low", d.write_drain_low, 0, 0.99, "ratio",
          "a write drain ends at this fraction of queue_entries when reads wait"),
      f64("dram.activate_pj", d.activate_pj, 0, 1e7, "pJ",
          "energy of one activate and its precharge in one channel (set by dram.part)"),
      f64("dram.read_burst_pj", d.read_burst_pj, 0, 1e7, "pJ",
          "energy of one read burst of burst_bytes, core and I/O as the part's source gives them "
          "(set by dram.part)"),
      f64("dram.write_burst_pj", d.write_burst_pj, 0, 1e7, "pJ",
          "energy of one write burst (set by dram.part)"),
      f64("dram.refresh_pj", d.refresh_pj, 0, 1e9, "pJ",
          "energy of one all-bank refresh of a rank (set by dram.part)"),
      f64("dram.background_mw", d.background_mw, 0, 1e6, "mW",
          "standby power of one channel with its banks precharged (IDD2N x VDD over its devices; "
          "set by dram.part), drawn for the whole run: energy.dram_background"),
      text("dram.address_mapping", d.address_mapping, {},
           "fields row, rank, bank, column, channel and optionally bankgroup from most to least "
           "significant, ':'-separated; without bankgroup the group is the bank's top bits"),
  };
  for (auto& p : dram) visit(p);
  EnergyConfig& e = c.energy;
  std::vector<ParameterInfo> energy = {
      f64("energy.sram_scale", e.sram_scale, 0, 100, "ratio",
          "a further factor on every cache access energy (another SRAM design), which otherwise "
          "follows the cache's size in SimTRaX's 65 nm CACTI table (1 bank, 64-byte lines: "
          "16 KiB 126 pJ, 512 KiB 642 pJ, 4 MiB 1645 pJ) scaled to energy.process_nm"),
      u32("energy.process_nm", e.process_nm, 7, 65, "nm",
          "process node of the accelerator: the unit, cache and crossbar energies of the 65 nm "
          "machine are scaled to it by Stillmaker and Baas's equations (65, 45, 32, 20, 16, 14, "
          "10, 7; DRAM is its own chip and is not scaled)"),
      f64("energy.vdd", e.vdd, 0, 2, "V",
          "supply voltage at energy.process_nm; 0: the node's nominal (65 nm 1.1, 45 nm 1.0, "
          "32 nm 0.9, 20 nm 0.9, 16 nm 0.85, 14 nm 0.8, 10 nm 0.75, 7 nm 0.7 V)"),
      f64("energy.box_test_pj", e.box_test_pj, 0, 1e6, "pJ",
          "one ray-box slab test: 6 multiplies, 6 adds, 13 min/max/compares at SimTRaX's 65 nm "
          "unit energies (FPMUL 14.2, FPADD 7.4, FPMIN 0.536 pJ)"),
      f64("energy.triangle_test_pj", e.triangle_test_pj, 0, 1e6, "pJ",
          "one ray-triangle test: Moeller-Trumbore's 27 multiplies, 24 adds, 6 compares and a "
          "reciprocal at SimTRaX's 65 nm unit energies (FPINV 156.3 pJ)"),
      f64("energy.anyhit_test_pj", e.anyhit_test_pj, 0, 1e6, "pJ",
          "one alpha test of the any-hit stage: UV interpolation and texel address (8 multiplies, "
          "8 adds) and the alpha compare at SimTRaX's 65 nm unit energies"),
      f64("energy.xfm_pj", e.xfm_pj, 0, 1e6, "pJ",
          "one instance transform (XFM op): origin and direction through a 3x4 matrix, 18 "
          "multiplies and 15 adds at SimTRaX's 65 nm unit energies"),
      f64("energy.noc_byte_pj", e.noc_byte_pj, 0, 1e6, "pJ",
          "one byte through the crossbar: 0.6 pJ/bit, a 45 nm 4x4 mesh's delivered energy "
          "(Park et al., DAC 2012: 892 Gb/s at 531 mW)"),
  };
  for (auto& p : energy) visit(p);
  std::vector<ParameterInfo> stats = {
      text("stats.accounting", c.accounting, {"on", "off"},
           "the exclusive cycle accounting of every unit (busy, waiting by level, blocked, idle; "
           "the timeline draws it): off saves its cost (about 5% of the lt and cycle levels' "
           "instructions), and its stats are then not reported; no other stat changes"),
  };
  for (auto& p : stats) visit(p);
}

double cache_access_pj(uint64_t size_bytes) {
  // SimTRaX (dkoptacs/simtrax) samples/configs/dcacheparams.txt, one bank, 64-byte
  // lines, nJ in the file: 8 KiB .. 4 MiB.
  static const double kPj[] = {91.7, 126.4, 168.2, 235.8, 321.9, 457.8, 641.6, 904.3, 1165.6, 1645.0};
  const double x = std::log2(std::max<double>(1, double(size_bytes))) - 13;  // 0 at 8 KiB
  const int last = int(sizeof(kPj) / sizeof(kPj[0])) - 1;
  const int i = std::clamp(int(std::floor(x)), 0, last - 1);
  const double v = kPj[i] + (x - i) * (kPj[i + 1] - kPj[i]);  // beyond the ends: the end slope
  return std::max(1.0, v);
}

namespace {
// Stillmaker and Baas, "Scaling equations for the accurate prediction of CMOS device
// performance from 180 nm to 7 nm", Integration 58 (2017): energy of their benchmark
// circuits fitted as a V^2 + b V + c per node (65 nm: commercial library data; 45 and
// 32 nm: PTM high-performance; 20-7 nm: PTM-MG high-performance FinFETs). Only the
// ratio of two nodes' values is used. Nominal supplies: CACTI's 65 nm (1.1 V), PTM's
// and PTM-MG's nominal voltages for the others.
struct ProcessNode {
  uint32_t nm;
  double a, b, c, nominal_vdd;
};
constexpr ProcessNode kProcessNodes[] = {
    {65, 3.755, -4.398, 1.975, 1.1},     {45, 1.018, -0.3107, 0.1539, 1.0},
    {32, 0.8367, -0.4341, 0.1701, 0.9},  {20, 0.373, -0.1582, 0.04104, 0.9},
    {16, 0.2958, -0.1241, 0.03024, 0.85}, {14, 0.2363, -0.09675, 0.02239, 0.8},
    {10, 0.2068, -0.09311, 0.02375, 0.75}, {7, 0.1776, -0.09097, 0.02447, 0.7},
};
const ProcessNode& process_node(uint32_t nm) {
  for (const ProcessNode& n : kProcessNodes)
    if (n.nm == nm) return n;
  std::string all;
  for (const ProcessNode& n : kProcessNodes) all += (all.empty() ? "" : ", ") + std::to_string(n.nm);
  throw InputError("energy.process_nm", std::to_string(nm) + " nm is not a node of the scaling table (" +
                                            all + ")");
}
double scaled_energy(const ProcessNode& n, double vdd) { return (n.a * vdd + n.b) * vdd + n.c; }
}  // namespace

std::vector<uint32_t> process_nodes() {
  std::vector<uint32_t> out;
  for (const ProcessNode& n : kProcessNodes) out.push_back(n.nm);
  return out;
}

double nominal_vdd(uint32_t nm) { return process_node(nm).nominal_vdd; }

double process_energy_factor(uint32_t from_nm, uint32_t to_nm, double vdd) {
  const ProcessNode& from = process_node(from_nm);
  const ProcessNode& to = process_node(to_nm);
  return scaled_energy(to, vdd > 0 ? vdd : to.nominal_vdd) / scaled_energy(from, from.nominal_vdd);
}

namespace {

// Timings in tCK as public DRAM simulators configure these parts (values are
// JEDEC-class facts; nothing of those simulators' code is used):
// - lpddr4-3200: DRAMSys (tukl-msd/DRAMSys)
//   DRAMSys/library/resources/configs/memspecs/JEDEC_8Gb_LPDDR4-3200_16bit.json:
//   tCK 0.625 ns, RL 28, WL 14, tRCD 29, tRPpb 29, tRAS 68, tRRD 16, tFAW 64, tCCD 8,
//   tWTR 16, tWR 29, tRTP 12, tRTRS 1, tREFI 6246, tRFCab 448 (280 ns, 8 Gb per channel),
//   8 banks, 1024 columns of 16 bits. The same speed bin in Ramulator
//   (CMU-SAFARI/ramulator src/LPDDR4.h, LPDDR4_3200) has tRCD 29, tRAS 68, tRRD 16,
//   tFAW 64, tWTR 16. The channel is 32 data bits of two x16 dies in lockstep, so a
//   BL16 burst (8 tCK) carries 64 bytes and a row is two dies' 2 KiB pages = 4 KiB.
//   No bank groups: tRRD, tCCD and tWTR are the same for S and L.
// - ddr4-2400: DRAMsim3 (umd-memsys/DRAMsim3) configs/DDR4_8Gb_x8_2400.ini: tCK 0.83 ns
//   (833 ps for 2400 MT/s), CL 17, CWL 12, tRCD 17, tRP 17, tRAS 39, tRRD_S 4, tRRD_L 6,
//   tFAW 26, tCCD_S 4, tCCD_L 6, tWTR_S 3, tWTR_L 9, tWR 18, tRTP 9, tRTRS 1, tREFI 9360,
//   tRFC 420, BL8 = 4 tCK on a 64-bit channel (64 B per burst), 4 bank groups x 4 banks,
//   1024 columns x 8 devices x 8 bits = 8 KiB rows.
// - gddr6: Ramulator2 (CMU-SAFARI/ramulator2) python/ramulator/dram/gddr6.py, timing
//   preset GDDR6_14000_1350mV_double and organisation GDDR6_8Gb_x16: 14 Gb/s per pin,
//   tCK 0.57 ns, nBL 2 (BL16 on a x16 channel = 32 B per burst), CL 24, CWL 6,
//   tRCDRD 27, tRCDWR 16, tRP 27, tRAS 53, tRRD_S/L 8/8, tFAW 29, tCCD_S/L 2/4,
//   tWTR_S/L 9/11, tWR 27, tRTP 4, tREFI 3333, tRFCab 211, 4 bank groups x 4 banks,
//   1024 columns of 16 bits = 2 KiB rows. DRAMsim3 configs/GDDR6_8Gb_x16.ini agrees on
//   the row timings' scale (tRP 24, tRAS 54; the earlier 15/32 matched neither) and
//   gives tRTRS 1.
// - lpddr5: LPDDR5-6400, Ramulator2 python/ramulator/dram/lpddr5.py, timing preset
//   LPDDR5_6400 and organisation LPDDR5_8Gb_x16 (bank-group mode): tCK 1.25 ns (CK
//   800 MHz, WCK 4:1), nBL_min 2 (BL16 on a x16 channel = 32 B per burst), CL 17, CWL 9,
//   tRCD 15, tRPpb 15, tRAS 34, tWR 28, tRTP 8, tCCD_S/L 2/4, tWTR_S/L 5/10, and the
//   secondary timings that file derives: tRRD_S/L 4/4 (5 ns), tFAW 16 (20 ns), tREFI 3125
//   (3906 ns), tRFCab 168 (210 ns, 8 Gb); its read-to-write rule CL + BL + 2 - CWL gives
//   tRTRS 2. 4 bank groups x 4 banks, 1024 columns of 16 bits = 2 KiB rows.
// Read-to-write follows from the data bus (DRAMsim3's RL + BL - WL + tRTRS), write-to-read
// is WL + BL + tWTR, write-to-precharge WL + BL + tWR, as both simulators derive them.
//
// Energy per command of one channel: DRAM core energy (no I/O, no termination)
// from the parts' IDD currents with DRAMPower's formulas, E_act = (IDD0 tRC - IDD3N
// tRAS - IDD2N tRP) VDD, E_rd = (IDD4R - IDD3N) VDD tBURST, E_wr likewise with
// IDD4W, E_ref = (IDD5B - IDD3N) VDD tRFC:
// - lpddr4-3200: DRAMSys configs/memspec/JEDEC_8Gb_LPDDR4-3200_16bit.json currents,
//   per x16 die ACT 1.2 nJ, 32 B read 1.35 nJ, write 0.99 nJ, REF 22 nJ; a channel
//   is two dies in lockstep.
// - ddr4-2400: DRAMSys configs/memspec/MICRON_4Gb_DDR4-2400_8bit_A.json, per x8 chip
//   ACT 1.0 nJ, 8 B read 0.56 nJ, write 0.50 nJ, REF 23 nJ; eight chips a rank.
// - gddr6: Arches (Haydelj/arches-v2 units/ramulator/unit-GDDR6.cpp, VDD 1.35 V,
//   IDD0 71, IDD2N 60, IDD3N 61, IDD4R 248, IDD4W 231, IDD5B 286 mA) with the timings
//   below: ACT 0.67 nJ, 32 B read 0.29 nJ, write 0.26 nJ, REF 36 nJ per x16 channel.
//   With I/O GDDR6 is quoted at about 7.5 pJ/bit, 6.8 times this core figure.
// - lpddr5: no public LPDDR5 current set was found; the LPDDR4-3200 die's figures
//   stand in (per x16 channel), which likely overstates LPDDR5.
// Background: precharge standby, IDD2N x VDD of the channel's devices, from the same
// current sets (a floor: with a row open the device draws IDD3N, 3-15% more):
// - lpddr4-3200: per die IDD2N 2.0 mA at VDD1 1.8 V, 27 mA at VDD2 1.1 V, 0.75 mA at
//   VDDQ 1.1 V = 34.1 mW; two dies = 68.3 mW.
// - ddr4-2400: 38.25 mA at 1.2 V per x8 chip, eight chips = 367 mW.
// - gddr6: 60 mA at 1.35 V = 81 mW per x16 channel.
// - lpddr5: one LPDDR4 die per x16 channel, 34.1 mW (no LPDDR5 currents found).
const std::vector<DramPart> kDramParts = {
    // name, MT/s, channel bits,
    //   tCK ps, CL, CWL, tRCD, tRCD write, tRP, tRAS,
    //   tRRD_S, tRRD_L, tFAW, tCCD_S, tCCD_L, tWTR_S, tWTR_L,
    //   tWR, tRTP, tRTRS, tREFI, tRFC,
    //   burst tCK, burst bytes, bank groups, banks, row bytes,
    //   ACT, RD burst, WR burst, REF pJ, background mW, timing source, energy source
    {"lpddr4-3200", 3200, 32,
     625, 28, 14, 29, 29, 29, 68,
     16, 16, 64, 8, 8, 16, 16,
     29, 12, 1, 6246, 448,
     8, 64, 1, 8, 4096,
     2400, 2700, 1980, 44000, 68.3,
     "DRAMSys memspec JEDEC_8Gb_LPDDR4-3200_16bit (two x16 dies in lockstep); Ramulator LPDDR4_3200 agrees",
     "DRAMSys JEDEC_8Gb_LPDDR4-3200_16bit currents, DRAMPower's formulas"},
    {"ddr4-2400", 2400, 64,
     833, 17, 12, 17, 17, 17, 39,
     4, 6, 26, 4, 6, 3, 9,
     18, 9, 1, 9360, 420,
     4, 64, 4, 16, 8192,
     8100, 4480, 3990, 184000, 367,
     "DRAMsim3 configs/DDR4_8Gb_x8_2400.ini",
     "DRAMSys MICRON_4Gb_DDR4-2400_8bit_A currents (eight x8 chips), DRAMPower's formulas"},
    {"gddr6", 14000, 16,
     570, 24, 6, 27, 16, 27, 53,
     8, 8, 29, 2, 4, 9, 11,
     27, 4, 1, 3333, 211,
     2, 32, 4, 16, 2048,
     670, 290, 260, 36000, 81,
     "Ramulator2 gddr6.py GDDR6_14000_1350mV_double, GDDR6_8Gb_x16; DRAMsim3 GDDR6_8Gb_x16 for tRTRS",
     "Arches (Haydelj/arches-v2) GDDR6 IDD currents at 1.35 V, DRAMPower's formulas"},
    {"lpddr5", 6400, 16,
     1250, 17, 9, 15, 15, 15, 34,
     4, 4, 16, 2, 4, 5, 10,
     28, 8, 2, 3125, 168,
     2, 32, 4, 16, 2048,
     1200, 1350, 990, 22000, 34.1,
     "Ramulator2 lpddr5.py LPDDR5_6400, LPDDR5_8Gb_x16 (bank-group mode)",
     "none public: the LPDDR4-3200 die's figures per x16 channel (likely high)"},
};

}  // namespace

const std::vector<DramPart>& dram_parts() { return kDramParts; }

std::vector<std::string> dram_part_names() {
  std::vector<std::string> names;
  for (const DramPart& p : kDramParts) names.push_back(p.name);
  return names;
}

void apply_dram_part(DramConfig& d, const std::string& part) {
  const auto row = std::find_if(kDramParts.begin(), kDramParts.end(),
                                [&](const DramPart& p) { return part == p.name; });
  if (row == kDramParts.end()) {
    std::string all;
    for (auto& n : dram_part_names()) all += (all.empty() ? "" : " | ") + n;
    throw InputError("dram.part", "unknown DRAM part '" + part + "' (" + all + ")");
  }
  const DramPart& p = *row;
  d.tck_ps = p.tck_ps, d.tcl = p.tcl, d.tcwl = p.tcwl, d.trcd = p.trcd, d.trcd_write = p.trcd_write;
  d.trp = p.trp, d.tras = p.tras;
  d.trrd_s = p.trrd_s, d.trrd_l = p.trrd_l, d.tfaw = p.tfaw, d.tccd_s = p.tccd_s, d.tccd_l = p.tccd_l;
  d.twtr_s = p.twtr_s, d.twtr_l = p.twtr_l;
  d.twr = p.twr, d.trtp = p.trtp, d.trtrs = p.trtrs, d.trefi = p.trefi, d.trfc = p.trfc;
  d.burst_cycles = p.burst_cycles, d.burst_bytes = p.burst_bytes, d.bank_groups = p.bank_groups;
  d.banks = p.banks, d.row_bytes = p.row_bytes;
  d.activate_pj = p.activate_pj, d.read_burst_pj = p.read_burst_pj, d.write_burst_pj = p.write_burst_pj;
  d.refresh_pj = p.refresh_pj, d.background_mw = p.background_mw;
  d.part = part;
}

std::vector<std::string> preset_names() { return {"mobile", "desktop", "mobile-gpu", "desktop-gpu"}; }

std::string preset_sources(const std::string& name) {
  if (name == "mobile")
    return "The patent's target class: one small RT accelerator in a phone SoC, 2 channels of "
           "LPDDR4-3200 (51.2 GB/s).";
  if (name == "desktop")
    return "One larger RT accelerator (8 TRV units) on dual-channel DDR4-2400 (38.4 GB/s): a "
           "discrete accelerator card, not a GPU.";
  if (name == "mobile-gpu")
    return "A mobile GPU with RT units, after Vulkan-Sim's MOBILE configuration\n"
           "(ubc-aamodt-group/vulkan-sim configs/tested-cfgs/MOBILE/gpgpusim.config since commit\n"
           "67447b9a): 8 SMs with one RT unit each (cores = 8) at 1365 MHz; gpgpu_rt_max_warps 4 =\n"
           "128 rays in flight per RT unit (trv.ray_slots = 128); an RT unit reading through its\n"
           "SM's 32 KiB L1 (split here into 16 KiB node + 16 KiB triangle caches, 20-cycle hits as\n"
           "its L1D); internal-node and leaf test latency 8 cycles (gpgpu_rt_intersection_latency);\n"
           "64-byte 6-wide nodes (GEN_RT_BVH_INTERNAL_NODE is 16 dwords: memory.node_format =\n"
           "bvh6-64q); 4 memory channels of 16 bits with one L2 slice each. Vulkan-Sim's slices\n"
           "are 128 KiB (512 KiB L2); here 256 KiB (1 MiB), within Arm Immortalis-G720's stated\n"
           "2 or 4 slices of up to 1 MiB. Memory: LPDDR5-6400 (Ramulator2 timings), 4 x 16 bit\n"
           "= 51.2 GB/s, as a current phone SoC (Vulkan-Sim's MOBILE config keeps GDDR-class\n"
           "timings). Crossbar: 40-byte flits (icnt_flit_size) and 8-byte headers (gpgpu-sim's\n"
           "READ_PACKET_SIZE); L2 round trip 160 cycles (gpgpu_l2_rop_latency) as 30 cycles each\n"
           "way on the crossbar and 100 in the slice; 192 MSHRs per slice (dl2 MSHR A:192).";
  if (name == "desktop-gpu")
    return "An RTX 2060-class GPU, after Vulkan-Sim's and Accel-Sim's SM75_RTX2060 configuration\n"
           "(configs/tested-cfgs/SM75_RTX2060/gpgpusim.config) and NVIDIA's public figures:\n"
           "30 SMs with one RT core each (cores = 30) at the 1365 MHz base clock (1680 boost);\n"
           "128 rays in flight per RT core (gpgpu_rt_max_warps 4 x 32); the RT core reads\n"
           "through its SM's L1 (Vulkan-Sim: 64 KiB, 20-cycle hits; here 32 KiB node + 32 KiB\n"
           "triangle caches); 8-cycle node and leaf tests; 64-byte 6-wide nodes (bvh6-64q).\n"
           "Memory: GDDR6 at 14 Gb/s on a 192-bit bus as 12 channels of 16 bits (gpgpu_n_mem 12,\n"
           "gpgpu_dram_buswidth 2) = 336 GB/s; Ramulator2's GDDR6_14000 timings; FR-FCFS queues of\n"
           "64. L2: 3 MiB in 12 slices of 256 KiB, one per channel (Vulkan-Sim has 24 sub-\n"
           "partitions of 128 KiB, two per channel). Crossbar: 40-byte flits, 8-byte headers,\n"
           "160-cycle L2 round trip (gpgpu_l2_rop_latency) as 30 cycles each way plus 100 in the\n"
           "slice; 192 MSHRs per slice. rtsim caches have no sectors, so lines are 64 bytes: the\n"
           "two 32-byte sectors a GPU fetches for one 64-byte node.";
  throw InputError("preset", "unknown preset '" + name + "'");
}

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
    c.l1_texture = {32 * 1024, 64, 4, 2, 16};
    c.l2 = {2 * 1024 * 1024, 64, 16, 30, 64, 4, 1};
    apply_dram_part(c.dram, "ddr4-2400");
    c.dram.channels = 2;
  } else if (name == "mobile-gpu" || name == "desktop-gpu") {
    // preset_sources says where each number comes from.
    const bool desktop = name == "desktop-gpu";
    c.preset = name;
    c.clock_mhz = 1365;
    c.cores = desktop ? 30 : 8;
    c.trv_units = 1, c.trv_ray_slots = 128, c.trv_stack_entries = 16;
    c.trv_box_test_latency = 8, c.trv_boxes_per_pass = 6;
    c.ist_units = 1, c.ist_test_latency = 8, c.ist_queue_entries = 32;
    c.node_format = "bvh6-64q";
    const uint32_t l1 = desktop ? 32 * 1024 : 16 * 1024;
    c.l1_node = {l1, 64, 8, 20, 64};
    c.l1_triangle = {l1, 64, 8, 20, 64};
    c.l1_texture = {l1, 64, 8, 20, 64};  // as the other L1s: a GPU's L1/texture cache is one array
    c.l2_slices = desktop ? 12 : 4;
    c.l2 = {c.l2_slices * 256 * 1024, 64, 16, 100, 192, 1, 1};
    c.noc_latency_cycles = 30, c.noc_flit_bytes = 40, c.noc_header_bytes = 8;
    apply_dram_part(c.dram, desktop ? "gddr6" : "lpddr5");
    c.dram.channels = desktop ? 12 : 4;
    c.dram.queue_entries = 64;
  } else {
    throw InputError("preset", "unknown preset '" + name + "' (mobile | desktop | mobile-gpu | desktop-gpu)");
  }
  return c;
}

std::pair<uint32_t, uint32_t> parse_tile(const std::string& text) {
  uint32_t w = 0, h = 0;
  read_size_text(text, 4096, "raygen.tile", w, h);
  return {w, h};
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
  parse_tile(c.raygen_tile);
  process_node(c.energy.process_nm);  // one of the table's nodes, or a message naming them
  // Each key inside its range can still multiply past the host's memory (256 cores
  // x 256 units of 1 GiB L1s): refused here, before any model is built.
  std::string factors;
  const uint64_t model_bytes = model_memory_bytes(c, &factors);
  check_memory_budget(model_bytes, "hardware", "the model of this machine; largest part " + factors);
  if (c.triangle_packing == "line" && c.l1_triangle.line_bytes < c.triangle_bytes)
    throw InputError("memory.triangle_packing", "'line' needs l1_triangle.line_bytes (" +
                                                    std::to_string(c.l1_triangle.line_bytes) +
                                                    ") >= memory.triangle_bytes (" +
                                                    std::to_string(c.triangle_bytes) + ")");
  check_cache("l1_node", c.l1_node);
  check_cache("l1_triangle", c.l1_triangle);
  check_cache("l1_texture", c.l1_texture);
  // The L2's geometry is checked per slice (3 MB in 12 slices is 256 KiB each).
  if (c.l2.size_bytes % c.l2_slices != 0)
    throw InputError("l2.slices", "must divide l2.size_bytes (" + std::to_string(c.l2.size_bytes) + ")");
  if (c.l2_slices == 1 || !is_pow2(c.l2.line_bytes)) {
    check_cache("l2", c.l2);
  } else {
    try {
      check_cache("l2", c.l2_slice());
    } catch (const InputError&) {
      throw InputError("l2.slices", "a slice (l2.size_bytes / " + std::to_string(c.l2_slices) +
                                        " bytes) must hold a power-of-two number of sets of "
                                        "l2.line_bytes x l2.associativity");
    }
  }
  for (const auto& [core, caches] : c.core_caches) {
    const std::string key = "core." + std::to_string(core);
    if (core >= c.cores)
      throw InputError(key, "the machine has " + std::to_string(c.cores) + " cores (0.." +
                                std::to_string(c.cores - 1) + ")");
    check_cache(key + ".l1_node", caches.l1_node);
    check_cache(key + ".l1_triangle", caches.l1_triangle);
    if (caches.l1_node.line_bytes != c.l1_node.line_bytes)
      throw InputError(key + ".l1_node.line_bytes", "must equal l1_node.line_bytes (one line size per level)");
    if (caches.l1_triangle.line_bytes != c.l1_triangle.line_bytes)
      throw InputError(key + ".l1_triangle.line_bytes",
                       "must equal l1_triangle.line_bytes (one line size per level)");
  }
  if (c.l1_node.line_bytes > c.l2.line_bytes)
    throw InputError("l1_node.line_bytes", "must not exceed l2.line_bytes");
  if (c.l1_triangle.line_bytes > c.l2.line_bytes)
    throw InputError("l1_triangle.line_bytes", "must not exceed l2.line_bytes");
  if (c.l1_texture.line_bytes > c.l2.line_bytes)
    throw InputError("l1_texture.line_bytes", "must not exceed l2.line_bytes");
  const DramConfig& d = c.dram;
  if (!is_pow2(d.ranks)) throw InputError("dram.ranks", "must be a power of two");
  if (!is_pow2(d.banks)) throw InputError("dram.banks", "must be a power of two");
  if (!is_pow2(d.row_bytes)) throw InputError("dram.row_bytes", "must be a power of two");
  if (d.row_bytes < c.l2.line_bytes)
    throw InputError("dram.row_bytes", "must hold at least one l2 line");
  if (!is_pow2(d.bank_groups)) throw InputError("dram.bank_groups", "must be a power of two");
  if (d.banks % d.bank_groups != 0)
    throw InputError("dram.bank_groups",
                     "must divide dram.banks (" + std::to_string(d.banks) + ")");
  if (d.tccd_s > d.tccd_l) throw InputError("dram.tccd_s", "must not exceed dram.tccd_l");
  if (d.trrd_s > d.trrd_l) throw InputError("dram.trrd_s", "must not exceed dram.trrd_l");
  if (d.twtr_s > d.twtr_l) throw InputError("dram.twtr_s", "must not exceed dram.twtr_l");
  if (d.trefi != 0 && d.trfc >= d.trefi)
    throw InputError("dram.trfc", "must be shorter than dram.trefi");
  if (d.write_drain_low >= d.write_drain_high)
    throw InputError("dram.write_drain_low", "must be below dram.write_drain_high");
  // The mapping must name each field exactly once; bankgroup is optional.
  std::set<std::string> seen;
  std::stringstream in(d.address_mapping);
  std::string field;
  while (std::getline(in, field, ':')) {
    if (field != "row" && field != "rank" && field != "bank" && field != "column" &&
        field != "channel" && field != "bankgroup")
      throw InputError("dram.address_mapping", "unknown field '" + field + "'");
    if (!seen.insert(field).second)
      throw InputError("dram.address_mapping", "field '" + field + "' appears twice");
  }
  if (seen.size() - seen.count("bankgroup") != 5)
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
  std::vector<std::pair<std::string, const toml::node*>> per_core;
  // One key under two spellings ([l2] size_bytes and "l2.size_bytes", or a [core.1]
  // table and "core.1.l1_node.size_bytes") flattens to one name twice: refused, as
  // the campaign reader does, rather than keeping one of them silently.
  std::set<std::string> seen;
  for (auto& [key, node] : leaves) {
    if (!node->is_table() && !seen.insert(key).second)
      throw InputError(where + key, "is set twice (under two spellings: a table and a dotted, quoted key)");
    if (key.rfind("core.", 0) == 0) {  // after every machine-wide key, whatever the order
      per_core.emplace_back(key, node);
      continue;
    }
    auto it = params.find(key);
    if (it == params.end() && node->is_table()) {
      // An empty section ([l2] with no keys) is harmless; an empty table that is
      // no section at all is as unknown as any other key.
      auto section = params.lower_bound(key + ".");
      if (section != params.end() && section->first.rfind(key + ".", 0) == 0) continue;
    }
    if (it == params.end() && key == "memory.node_layout")
      throw InputError(where + key, "renamed memory.node_format (bvh2-64 stays bvh2-64; single-32 "
                                    "is now bvh2-32)");
    if (it == params.end()) throw InputError(where + key, "unknown key");
    set_from_toml(it->second, *node, where);
  }
  for (auto& [key, value] : per_core) {
    const toml::node* node = value;  // a plain variable: lambdas may not capture bindings (C++17)
    // core.<N>.<l1_node|l1_triangle>.<field>
    const size_t dot = key.find('.', 5);
    const std::string index = key.substr(5, dot == std::string::npos ? std::string::npos : dot - 5);
    uint64_t core_number = 0;
    if (!parse_unsigned(index, 0, 999, core_number))
      throw InputError(where + key, "per-core keys are core.<N>.<key>, N a core number (decimal, no leading zero)");
    const uint32_t core = uint32_t(core_number);
    const std::string rest = dot == std::string::npos ? "" : key.substr(dot + 1);
    auto [entry, fresh] = config.core_caches.try_emplace(core);
    if (fresh) entry->second = {config.l1_node, config.l1_triangle};
    bool known = false;
    for (const char* level : {"l1_node", "l1_triangle"}) {
      CacheConfig& cache = std::string(level) == "l1_node" ? entry->second.l1_node : entry->second.l1_triangle;
      cache_parameters(level, cache, "", [&](ParameterInfo& p) {
        if (p.key != rest) return;
        set_from_toml(p, *node, where + "core." + index + ".");
        known = true;
      });
    }
    if (!known)
      throw InputError(where + key, "unknown per-core key: a core can differ in its l1_node.* and "
                                    "l1_triangle.* caches only");
  }
  try {
    validate(config);
  } catch (const InputError& e) {
    throw InputError(where + e.what());
  }
  // A core whose caches equal the machine's is no override: dropped (after the
  // checks), so that the resolved configuration and a campaign job's key are the
  // same as without it.
  for (auto it = config.core_caches.begin(); it != config.core_caches.end();)
    it = it->second.l1_node == config.l1_node && it->second.l1_triangle == config.l1_triangle
             ? config.core_caches.erase(it)
             : std::next(it);
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
    throw InputError(preset_or_path,
                     "neither a preset (mobile | desktop | mobile-gpu | desktop-gpu) nor a file");
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
  for (auto& [index, caches] : config.core_caches)
    for (const char* level : {"l1_node", "l1_triangle"}) {
      const std::string core = std::to_string(index);  // lambdas may not capture bindings (C++17)
      cache_parameters(level, std::string(level) == "l1_node" ? caches.l1_node : caches.l1_triangle, "",
                       [&](ParameterInfo& p) {
                         const std::string field = p.key.substr(p.key.find('.') + 1);
                         out["core"][core][level][field] = *p.u32;
                       });
    }
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
