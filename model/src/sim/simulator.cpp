#include <rtsim/model/sim/stat_names.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/cycle/cycle_system.h>
#include <rtsim/model/sim/dram_reference.h>
#include <rtsim/model/sim/energy.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/memory_trace.h>
#include <rtsim/model/sim/ray_engine.h>
#include <rtsim/model/sim/simulator.h>
#include <rtsim/workloads/error.h>

#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <chrono>
#include <ctime>
#include <cmath>
#include <stdexcept>
#include <type_traits>

namespace rtsim::sim {

namespace {

double cpu_now() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + double(t.tv_nsec) * 1e-9;
}

uint64_t peak_rss_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports KiB
}

// A unit's cycles split exclusively (accounting.h): <prefix>.<bucket>_cycles for every
// bucket its kind has, adding up to time.cycles, its utilisation and its work (the
// work alone with stats.accounting off).
void report_unit(StatsRegistry& s, const std::string& prefix, const UnitTraits& kind, const CycleSplit& ps,
                 double cycle_ps, uint64_t work, const std::string& work_unit,
                 const std::string& work_description, bool accounted) {
  if (!accounted) return s.set(prefix + "." + work_unit, work, work_unit, work_description);
  const CycleSplit cycles = bucket_cycles(ps, cycle_ps);
  uint64_t total = 0;
  for (uint64_t c : cycles) total += c;
  for (CycleBucket b : kAllCycleBuckets)
    if (kind.has(b))
      s.set(prefix + "." + cycle_bucket_name(b) + "_cycles", cycles[size_t(b)], "cycles",
            cycle_bucket_meaning(b));
  s.set_real(prefix + ".utilisation", total ? double(cycles[size_t(CycleBucket::Busy)]) / double(total) : 0,
             "ratio", "busy cycles / simulated cycles");
  s.set(prefix + "." + work_unit, work, work_unit, work_description);
}

// Mean, least and most over a kind's units of each bucket and of utilisation:
// machine.<kind>.<bucket>_cycles.{mean,min,max}.
void report_rollup(StatsRegistry& s, const UnitTraits& kind, const std::vector<CycleSplit>& units,
                   double cycle_ps) {
  if (units.empty()) return;
  const std::string p = std::string("machine.") + kind.name + ".";
  const std::string of = std::string(" over the machine's ") + kind.name + " units";
  std::vector<CycleSplit> cycles;
  for (const CycleSplit& u : units) cycles.push_back(bucket_cycles(u, cycle_ps));
  const auto rollup = [&](const std::string& name, const std::string& unit, const std::string& what,
                          const std::function<double(const CycleSplit&)>& value) {
    double sum = 0, lo = INFINITY, hi = -INFINITY;
    for (const CycleSplit& c : cycles) {
      const double v = value(c);
      sum += v, lo = std::min(lo, v), hi = std::max(hi, v);
    }
    s.set_real(p + name + ".mean", sum / double(cycles.size()), unit, "mean" + of + " of the " + what);
    s.set_real(p + name + ".min", lo, unit, "least" + of + " of the " + what);
    s.set_real(p + name + ".max", hi, unit, "most" + of + " of the " + what);
  };
  for (CycleBucket b : kAllCycleBuckets)
    if (kind.has(b))
      rollup(std::string(cycle_bucket_name(b)) + "_cycles", "cycles", cycle_bucket_meaning(b),
             [b](const CycleSplit& c) { return double(c[size_t(b)]); });
  rollup("utilisation", "ratio", "busy cycles / simulated cycles", [](const CycleSplit& c) {
    uint64_t total = 0;
    for (uint64_t v : c) total += v;
    return total ? double(c[size_t(CycleBucket::Busy)]) / double(total) : 0.0;
  });
}

// Two-level trees: TRV split into the TLAS's and the BLASes' share, and the XFM ops.
// Op counts go under `p`, bytes under `bytes_p` (ops. and fetches. for the run's totals).
void report_levels(StatsRegistry& s, const std::string& p, const std::string& bytes_p, const CounterTotals& c,
                   const std::string& whose) {
  s.set(p + "tlas_trv_ops", c.tlas_trv_ops, "ops", "TRV ops in the TLAS" + whose);
  s.set(p + "blas_trv_ops", c.trv_ops - c.tlas_trv_ops, "ops", "TRV ops in the BLASes" + whose);
  s.set(p + "xfm_ops", c.xfm_ops, "ops",
        "XFM ops: rays transformed into an instance's object space (one instance record each)" + whose);
  s.set_real(p + "tlas_trv_ops_per_ray", c.per_ray(c.tlas_trv_ops), "ops/ray", "TLAS TRV ops / rays" + whose);
  s.set_real(p + "blas_trv_ops_per_ray", c.per_ray(c.trv_ops - c.tlas_trv_ops), "ops/ray",
             "BLAS TRV ops / rays" + whose);
  s.set_real(p + "xfm_ops_per_ray", c.per_ray(c.xfm_ops), "ops/ray", "XFM ops / rays" + whose);
  s.set_real(bytes_p + "tlas_node_bytes_per_ray", c.per_ray(c.tlas_node_bytes), "bytes/ray",
             "TLAS node-record bytes (before caches) / rays" + whose);
  s.set_real(bytes_p + "blas_node_bytes_per_ray", c.per_ray(c.node_bytes - c.tlas_node_bytes), "bytes/ray",
             "BLAS node-record bytes (before caches) / rays" + whose);
  s.set_real(bytes_p + "instance_bytes_per_ray", c.per_ray(c.instance_bytes), "bytes/ray",
             "instance-record bytes (before caches) / rays" + whose);
}

void report_counts(StatsRegistry& s, const std::array<CounterTotals, kRayTypeCount>& per_type, bool anyhit,
                   bool two_level) {
  CounterTotals total;
  for (auto& c : per_type) total.add(c);
  s.set("rays.total", total.rays, "rays", "rays simulated, all types");
  s.set("ops.trv", total.trv_ops, "ops", "TRV ops: BVH nodes processed");
  s.set("ops.ist", total.ist_ops, "ops", "IST ops: ray-triangle tests");
  s.set("ops.ist_exact_steps", total.ist_exact_steps, "steps",
        "IST edge functions and plane distances redone in double because float rounding "
        "could have decided them (a hardware unit's slow path)");
  s.set("ops.box_tests", total.box_tests, "tests", "ray-box slab tests");
  s.set_real("ops.per_ray", total.per_ray(total.ops()), "ops/ray", "(TRV + IST ops) / rays");
  s.set("fetches.node", total.node_fetches, "fetches", "node records read by TRV (before caches)");
  s.set("fetches.prim_ref", total.prim_ref_fetches, "fetches", "leaf prim-ref lists read by IST");
  s.set("fetches.triangle", total.triangle_fetches, "fetches",
        "triangle records read by IST (an any-hit ray may read some of its last step it does not test)");
  s.set("fetches.bytes", total.bytes(), "bytes", "bytes of all fetches before caches");
  s.set("stack.overflows", total.stack_overflows, "entries",
        "pushes that found the short stack full and spilled to memory");
  s.set("stack.refills", total.stack_refills, "entries", "spilled entries read back");
  for (RayType t : kAllRayTypes) {
    const CounterTotals& c = per_type[size_t(t)];
    if (c.rays == 0) continue;
    const std::string p = std::string("per_type.") + ray_type_name(t);
    s.set(p + ".rays", c.rays, "rays", std::string(ray_type_name(t)) + " rays");
    s.set(p + ".hits", c.hits, "rays", "rays that hit something");
    s.set(p + ".trv_ops", c.trv_ops, "ops", "TRV ops of these rays");
    s.set(p + ".ist_ops", c.ist_ops, "ops", "IST ops of these rays");
    s.set(p + ".node_fetches", c.node_fetches, "fetches", "node fetches of these rays");
    s.set(p + ".triangle_fetches", c.triangle_fetches, "fetches", "triangle fetches of these rays");
    s.set_real(p + ".ops_per_ray", c.per_ray(c.ops()), "ops/ray", "(TRV + IST ops) / rays");
    if (two_level) report_levels(s, p + ".", p + ".", c, " (these rays)");
    if (!anyhit) continue;
    s.set(p + ".anyhit_tests", c.anyhit_tests, "tests", "any-hit (alpha) tests of these rays");
    s.set_real(p + ".anyhit_tests_per_ray", c.per_ray(c.anyhit_tests), "tests/ray",
               "any-hit (alpha) tests of these rays / their count");
    s.set(p + ".anyhit_rejects", c.anyhit_rejects, "tests",
          "alpha tests of these rays whose texel let the ray through");
    s.set_real(p + ".texel_bytes_per_ray", c.per_ray(c.texel_bytes), "bytes/ray",
               "texel bytes the any-hit stage read for these rays (before caches) / their count");
    s.set_real(p + ".uv_bytes_per_ray", c.per_ray(c.uv_bytes), "bytes/ray",
               "UV-record bytes the any-hit stage read for these rays (before caches) / their count");
  }
  if (two_level) {
    report_levels(s, "ops.", "fetches.", total, "");
    s.set("fetches.instance", total.xfm_ops, "fetches", "instance records read by TRV (before caches)");
    s.set("fetches.instance_bytes", total.instance_bytes, "bytes", "instance-record bytes read (before caches)");
  }
  // The any-hit stage, only where built (a scene with alpha-tested materials).
  if (!anyhit) return;
  s.set("anyhit.tests", total.anyhit_tests, "tests",
        "any-hit (alpha) tests: hits on alpha-tested triangles nearer than the closest committed hit");
  s.set("anyhit.rejects", total.anyhit_rejects, "tests", "alpha tests whose texel let the ray through");
  s.set_real("anyhit.tests_per_ray", total.per_ray(total.anyhit_tests), "tests/ray", "anyhit.tests / rays");
  s.set_real("anyhit.reject_ratio",
             total.anyhit_tests ? double(total.anyhit_rejects) / double(total.anyhit_tests) : 0, "ratio",
             "anyhit.rejects / anyhit.tests");
  s.set("fetches.uv_bytes", total.uv_bytes, "bytes", "UV-record bytes the any-hit stage read (before caches)");
  s.set("fetches.texel_bytes", total.texel_bytes, "bytes", "texel bytes the any-hit stage read (before caches)");
}

// What one run of any level leaves to report, per instance of the machine
// (machine.h numbering). Each level fills it from its own components; the names
// and the accounting are this one function's.
struct MachineFigures {
  std::vector<CycleSplit> trv, ist;           // per TRV / IST unit: picoseconds per bucket
  std::vector<uint64_t> trv_passes, ist_tests;
  std::vector<CycleSplit> shading;            // per core; empty when nothing is shaded
  std::vector<uint64_t> shaded, spawned;      // per core
  std::vector<uint64_t> raygen_blocked_ps;    // per core (cycle level only)
  std::vector<uint64_t> trv_leaves_blocked;   // per TRV unit (cycle level only)
  // By ray type: the TRV and IST pipelines' time its work took, and (timed) its rays'
  // time from start to finish in a TRV slot.
  std::array<uint64_t, kRayTypeCount> trv_busy_ps_by_type{}, ist_busy_ps_by_type{}, ray_ps_by_type{};
  std::vector<const CacheModel*> l1_node, l1_triangle, l2;
  // The any-hit stages and their texture caches (alpha-tested scenes only).
  bool anyhit = false;
  std::vector<uint64_t> anyhit_tests;  // per IST unit
  std::vector<const CacheModel*> l1_texture;
  std::vector<uint64_t> l2_downstream_stall_ps, l2_downstream_refusals;  // per slice (cycle)
  const DramModel* dram = nullptr;
  const Crossbar* noc = nullptr;
  std::vector<const Stage*> stages;                  // the optional stages built (units/stage.h)
  std::vector<std::vector<CycleSplit>> stage_cycles;  // per stage, per instance (timed levels)
};

// The energy model's event counts from the figures (energy.h).
EnergyCounts energy_counts(const MachineFigures& f,
                           const std::array<CounterTotals, kRayTypeCount>& per_type,
                           const TrafficMatrix& dram_bytes, const DramConfig& dram) {
  EnergyCounts e;
  const auto level = [](const std::vector<const CacheModel*>& caches, double& pj, TrafficMatrix& bytes) {
    for (const CacheModel* c : caches) {
      pj += double(c->counters().accesses + c->counters().writebacks) *
            cache_access_pj(c->config().size_bytes);
      bytes.add(c->requested());
    }
  };
  level(f.l1_node, e.l1_node_pj, e.l1_node_bytes);
  level(f.l1_triangle, e.l1_triangle_pj, e.l1_triangle_bytes);
  level(f.l1_texture, e.l1_texture_pj, e.l1_texture_bytes);
  level(f.l2, e.l2_pj, e.l2_bytes);
  e.anyhit_built = f.anyhit;
  e.dram_bytes = dram_bytes;
  e.noc_bytes = f.noc->bytes();
  const DramModel::Counters& d = f.dram->counters();
  e.dram_activates = d.activates;
  e.dram_read_bursts = (d.bytes + dram.burst_bytes - 1) / dram.burst_bytes;
  e.dram_write_bursts = (d.bytes_written + dram.burst_bytes - 1) / dram.burst_bytes;
  e.dram_refreshes = d.refreshes;
  e.per_type = per_type;
  e.stages = f.stages;
  return e;
}

void report_machine(StatsRegistry& s, const HardwareConfig& config, const MachineShape& m,
                    const MachineFigures& f, const std::array<CounterTotals, kRayTypeCount>& per_type,
                    uint64_t sim_ps, bool timed) {
  const double cycle_ps = config.clock_period_ps();
  uint64_t rays = 0;
  for (const CounterTotals& t : per_type) rays += t.rays;
  const auto cycles = [&](uint64_t ps) { return uint64_t(std::llround(double(ps) / cycle_ps)); };
  const bool accounted = config.accounted();
  for (uint32_t u = 0; u < f.trv.size(); ++u)
    report_unit(s, m.trv_name(u), unit_traits(UnitKind::Trv), f.trv[u], cycle_ps, f.trv_passes[u], "passes",
                "box-test pipeline passes (a node takes ceil(children / trv.boxes_per_pass))", accounted);
  for (uint32_t u = 0; u < f.ist.size(); ++u)
    report_unit(s, m.ist_name(u), unit_traits(UnitKind::Ist), f.ist[u], cycle_ps, f.ist_tests[u], "tests",
                "triangle tests through the pipeline", accounted);
  for (uint32_t c = 0; c < f.shading.size(); ++c) {
    const std::string p = MachineShape::core_name(c) + ".shading";
    report_unit(s, p, unit_traits(UnitKind::Shading), f.shading[c], cycle_ps, f.shaded[c], "rays", "rays shaded",
                accounted);
    s.set(p + ".spawned", f.spawned[c], "rays", "secondary rays spawned");
  }
  for (uint32_t u = 0; f.anyhit && u < f.anyhit_tests.size(); ++u)
    s.set(m.ist_name(u) + ".anyhit_tests", f.anyhit_tests[u], "tests",
          "alpha tests the unit's any-hit stage ran (in its pipeline, beside the triangle tests)");
  for (uint32_t u = 0; u < f.trv_leaves_blocked.size(); ++u)
    s.set(m.trv_name(u) + ".leaves_blocked", f.trv_leaves_blocked[u], "leaves",
          "leaves that found the IST unit's queue full and waited for room");
  for (size_t k = 0; k < f.stages.size(); ++k) {
    const Stage& stage = *f.stages[k];
    stage.report(s, config, timed);
    for (uint32_t c = 0; timed && c < stage.instances(); ++c) {
      const StageWork w = stage.work(c);
      report_unit(s, MachineShape::core_name(c) + "." + stage.traits().name, stage.traits(), f.stage_cycles[k][c],
                  cycle_ps, w.count, w.unit, w.meaning, accounted);
    }
  }
  if (accounted) {
    report_rollup(s, unit_traits(UnitKind::Trv), f.trv, cycle_ps);
    report_rollup(s, unit_traits(UnitKind::Ist), f.ist, cycle_ps);
    report_rollup(s, unit_traits(UnitKind::Shading), f.shading, cycle_ps);
    for (size_t k = 0; timed && k < f.stages.size(); ++k)
      report_rollup(s, f.stages[k]->traits(), f.stage_cycles[k], cycle_ps);
  }
  for (uint32_t c = 0; c < f.raygen_blocked_ps.size(); ++c)
    s.set(MachineShape::core_name(c) + ".raygen.blocked_cycles", cycles(f.raygen_blocked_ps[c]),
          "cycles", "cycles a ready ray found no free TRV slot of its core");
  for (RayType t : kAllRayTypes) {
    const size_t k = size_t(t);
    if (per_type[k].rays == 0) continue;
    const std::string p = std::string("per_type.") + ray_type_name(t) + ".";
    s.set_real(p + "trv_busy_cycles", double(f.trv_busy_ps_by_type[k]) / cycle_ps, "cycles",
               "busy cycles of the TRV units spent on these rays' nodes (summed over units)");
    s.set_real(p + "ist_busy_cycles", double(f.ist_busy_ps_by_type[k]) / cycle_ps, "cycles",
               "busy cycles of the IST units spent on these rays' triangle tests (summed over units)");
    if (timed)
      s.set_real(p + "cycles_per_ray", double(f.ray_ps_by_type[k]) / cycle_ps / double(per_type[k].rays),
                 "cycles/ray", "mean cycles from a ray's start in a TRV slot to its finish");
  }
  s.set("machine.cores", m.cores, "cores", "RT cores");
  uint64_t passes = 0;
  for (uint64_t p : f.trv_passes) passes += p;
  s.set("machine.trv_passes", passes, "passes", "box-test pipeline passes of every TRV unit");
  s.set_real("machine.peak_trv_passes_per_cycle", double(m.trv_units()) * config.trv_nodes_per_cycle,
             "passes/cycle", "TRV units x trv.nodes_per_cycle: no run passes more per cycle");
  s.set_real("machine.peak_dram_bytes_per_cycle",
             f.dram->peak_bytes_per_second() * cycle_ps * 1e-12, "bytes/cycle",
             "the DRAM's peak bandwidth per accelerator cycle (reads and writes share it)");
  report_cache_group(s, "l1_node.all", f.l1_node);
  for (uint32_t u = 0; u < f.l1_node.size(); ++u) f.l1_node[u]->report(s, m.l1_node_name(u));
  report_cache_group(s, "l1_triangle.all", f.l1_triangle);
  for (uint32_t u = 0; u < f.l1_triangle.size(); ++u)
    f.l1_triangle[u]->report(s, m.l1_triangle_name(u));
  if (f.anyhit) {
    report_cache_group(s, "l1_texture.all", f.l1_texture);
    for (uint32_t u = 0; u < f.l1_texture.size(); ++u) f.l1_texture[u]->report(s, m.l1_texture_name(u));
  }
  // The L2 as a whole under l2.*, each slice under l2.slice<s>.*.
  report_cache_group(s, "l2", f.l2);
  TrafficMatrix filled;
  uint64_t max_accesses = 0, sum_accesses = 0;
  for (uint32_t i = 0; i < f.l2.size(); ++i) {
    filled.add(f.l2[i]->filled());
    max_accesses = std::max(max_accesses, f.l2[i]->counters().accesses);
    sum_accesses += f.l2[i]->counters().accesses;
    if (f.l2.size() > 1) f.l2[i]->report(s, MachineShape::slice_name(i));
  }
  s.set_real("l2.slice_balance",
             sum_accesses ? double(max_accesses) * double(f.l2.size()) / double(sum_accesses) : 1.0,
             "ratio", "the busiest slice's accesses / the mean slice's (1: even)");
  if (!f.l2_downstream_stall_ps.empty()) {
    uint64_t stall = 0, refusals = 0;
    for (uint32_t i = 0; i < f.l2.size(); ++i) {
      stall += f.l2_downstream_stall_ps[i];
      refusals += f.l2_downstream_refusals[i];
      if (f.l2.size() == 1) continue;
      const std::string p = MachineShape::slice_name(i);
      s.set(p + ".downstream_stall_cycles", cycles(f.l2_downstream_stall_ps[i]), "cycles",
            "cycles the slice's outbound queue waited because the DRAM queue was full");
      s.set(p + ".downstream_refusals", f.l2_downstream_refusals[i], "requests",
            "requests the DRAM did not take at once (its channel queue was full)");
    }
    s.set("l2.downstream_stall_cycles", cycles(stall), "cycles",
          "cycles the L2's outbound queues waited because the DRAM queue was full (summed over slices)");
    s.set("l2.downstream_refusals", refusals, "requests",
          "requests the DRAM did not take at once (its channel queue was full)");
  }
  f.noc->report(s, "noc", sim_ps);
  f.dram->report(s, "dram", timed, timed, sim_ps);
  // Every DRAM byte read is an L2 fill: attribute them the same way.
  filled.report(s, stat::kDramBytesByType, "bytes read from DRAM");
  s.set_real("dram.bytes_per_ray", rays ? double(f.dram->counters().bytes) / double(rays) : 0,
             "bytes/ray", "DRAM bytes read / rays");
  EnergyCounts energy = energy_counts(f, per_type, filled, config.dram);
  // mW x ps = 1e-15 J = 1e-3 pJ.
  energy.dram_background_pj = config.dram.background_mw * config.dram.channels * double(sim_ps) * 1e-3;
  report_energy(s, config, energy);
}

void report_layout(StatsRegistry& s, const MemoryImage& image, uint64_t triangles) {
  const MemoryFootprint& f = image.footprint();
  s.set("memory.node_records", f.node_records, "records", "node records in memory");
  s.set("memory.node_bytes", f.node_bytes, "bytes", "bytes of node records");
  s.set("memory.prim_ref_bytes", f.prim_ref_bytes, "bytes", "bytes of leaf prim-ref lists");
  s.set("memory.triangle_records", f.triangle_records, "records",
        "triangle records (inline storage: one per leaf reference)");
  s.set("memory.triangle_bytes", f.triangle_bytes, "bytes", "bytes of triangle records, padding included");
  if (image.has_alpha_data()) {
    s.set("memory.uv_bytes", f.uv_bytes, "bytes", "bytes of UV records (alpha testing)");
    s.set("memory.texture_bytes", f.texture_bytes, "bytes", "bytes of the alpha textures (RGBA8)");
  }
  if (image.two_level()) {
    s.set("memory.tlas_node_records", f.tlas_node_records, "records", "node records of the TLAS (in node_records)");
    s.set("memory.instance_records", f.instance_records, "records", "instance records (64 B each)");
    s.set("memory.instance_bytes", f.instance_bytes, "bytes", "bytes of instance records");
  }
  s.set("memory.total_bytes", f.total_bytes(), "bytes",
        "footprint of the BVH and its triangles (and UVs and textures, where alpha-tested; instance "
        "records, where instanced)");
  s.set_real("memory.bytes_per_triangle", triangles ? double(f.total_bytes()) / double(triangles) : 0,
             "bytes/triangle", "footprint / scene triangles");
}

void report_time(StatsRegistry& s, const HardwareConfig& c, uint64_t sim_ps, uint64_t rays,
                 uint32_t frames) {
  const double cycle_ps = c.clock_period_ps();
  const uint64_t cycles = uint64_t(std::llround(double(sim_ps) / cycle_ps));
  // One description at every level: the functional level's time is its estimate.
  const std::string how = " (the functional level: an analytic estimate)";
  s.set("time.cycles", cycles, "cycles", "simulated accelerator cycles of the last frame" + how);
  s.set_real("time.seconds", double(sim_ps) * 1e-12, "s", "simulated time of the last frame" + how);
  s.set_real("time.rays_per_second", sim_ps ? double(rays) / (double(sim_ps) * 1e-12) : 0, "rays/s",
             "rays per second at the simulated clock" + how);
  s.set("time.clock_mhz", c.clock_mhz, "MHz", "accelerator clock");
  s.set("time.frames", frames, "frames",
        "frames simulated back to back (the same rays, caches warm); every figure is the last's");
}

void report_frames(StatsRegistry& s, const std::vector<FrameFigures>& history,
                   const HardwareConfig& c, bool untimed) {
  if (history.size() < 2) return;
  for (size_t f = 0; f < history.size(); ++f) {
    const FrameFigures& h = history[f];
    // One description for every frame (one name, one meaning): frame1 is the cold one.
    const std::string p = "frames.frame" + std::to_string(f + 1);
    const std::string which = " (frame1: cold caches)";
    s.set(p + ".dram_bytes", h.dram_bytes_read, "bytes", "bytes read from DRAM in this frame" + which);
    s.set(p + ".dram_bytes_written", h.dram_bytes_written, "bytes", "bytes written to DRAM in this frame");
    s.set_real(p + ".dram_bytes_per_ray", h.rays ? double(h.dram_bytes_read) / double(h.rays) : 0,
               "bytes/ray", "DRAM bytes read / rays in this frame" + which);
    if (!untimed)
      s.set(p + ".cycles", uint64_t(std::llround(double(h.simulated_ps) / c.clock_period_ps())),
            "cycles", "simulated cycles of this frame" + which);
  }
}

// Every unit, cache, crossbar port and DRAM channel of a timed machine gets its
// track on the timeline: units and L1s under their core, L2 slices, the crossbar's
// ports and the DRAM channels under "memory".
template <class Cache>
void draw_machine(Timeline& t, const HardwareConfig& config, const MachineShape& m,
                  const std::vector<UnitAccounting*>& trv, const std::vector<UnitAccounting*>& ist,
                  const std::vector<UnitAccounting*>& shading, RayDispatcher& dispatcher,
                  const std::vector<Cache*>& l1_node,
                  const std::vector<Cache*>& l1_triangle, const std::vector<Cache*>& l1_texture,
                  const std::vector<Cache*>& l2, Crossbar& noc, DramModel& dram) {
  const auto core = [](uint32_t c) { return MachineShape::core_name(c); };
  for (uint32_t u = 0; u < trv.size(); ++u) {
    trv[u]->draw_on(&t, t.track(core(m.core_of_trv(u)), m.trv_name(u)));
    l1_node[u]->draw_on(&t, t.track(core(m.core_of_trv(u)), m.l1_node_name(u) + " misses", true));
  }
  for (uint32_t i = 0; i < ist.size(); ++i) {
    ist[i]->draw_on(&t, t.track(core(m.core_of_ist(i)), m.ist_name(i)));
    l1_triangle[i]->draw_on(&t, t.track(core(m.core_of_ist(i)), m.l1_triangle_name(i) + " misses", true));
    if (i < l1_texture.size())  // alpha-tested scenes only
      l1_texture[i]->draw_on(&t, t.track(core(m.core_of_ist(i)), m.l1_texture_name(i) + " misses", true));
  }
  for (uint32_t c = 0; c < shading.size(); ++c) shading[c]->draw_on(&t, t.track(core(c), core(c) + ".shading"));
  for (Stage* stage : dispatcher.stages())
    for (uint32_t c = 0; c < stage->instances(); ++c)
      stage->accounting(c).draw_on(&t, t.track(core(c), core(c) + "." + stage->traits().name));
  for (uint32_t s = 0; s < l2.size(); ++s)
    l2[s]->draw_on(&t, t.track("memory", MachineShape::slice_name(s) + " misses", true));
  std::vector<uint32_t> to_slice, to_core;
  for (uint32_t s = 0; s < m.l2_slices; ++s)
    to_slice.push_back(t.track("memory", "noc to " + MachineShape::slice_name(s), true));
  for (uint32_t c = 0; c < m.cores; ++c) to_core.push_back(t.track("memory", "noc to " + core(c), true));
  noc.draw_on(&t, to_slice, to_core);
  std::vector<uint32_t> channels;
  for (uint32_t c = 0; c < config.dram.channels; ++c)
    channels.push_back(t.track("memory", "dram channel " + std::to_string(c), true));
  const uint64_t tck = config.dram.tck_ps;
  dram.set_command_observer([&t, channels, tck](const DramCommand& c) {
    t.span(channels[c.channel], dram_command_name(c.kind), c.time_ps, c.time_ps + tck,
           "\"rank\":" + std::to_string(c.rank) + ",\"bank\":" + std::to_string(c.bank) +
               ",\"row\":" + std::to_string(c.row));
  });
}

bool& systemc_used() {
  static bool used = false;
  return used;
}

}  // namespace

MemoryLayoutConfig memory_layout_for(const HardwareConfig& c) {
  MemoryLayoutConfig layout;
  layout.node_format = c.node_format;
  layout.node_order = c.node_order == "breadth-first" ? NodeOrder::BreadthFirst : NodeOrder::DepthFirst;
  layout.triangle_storage =
      c.triangle_storage == "inline" ? TriangleStorage::Inline : TriangleStorage::Indexed;
  layout.triangle_packing = c.triangle_packing == "line" ? TrianglePacking::Line : TrianglePacking::Packed;
  layout.triangle_bytes = c.triangle_bytes;
  layout.line_bytes = c.l1_triangle.line_bytes;
  return layout;
}

TraversalConfig traversal_config_for(const HardwareConfig& c) {
  TraversalConfig t;
  t.stack_limit = c.trv_stack_entries;
  t.stack_entry_bytes = c.trv_stack_entry_bytes;
  t.overflow_policy = StackOverflowPolicy::SpillToMemory;
  t.triangles_per_step = c.ist_triangles_in_flight;
  return t;
}

namespace {

using Progress = std::function<void(uint64_t)>;

template <typename T>
std::vector<const T*> pointers_to(const std::vector<T>& units) {
  std::vector<const T*> out;
  for (const T& u : units) out.push_back(&u);
  return out;
}

// Figures of the units (units/*.h), the same for every level. Timed, each unit's
// accounting (finished at the run's end) splits the time, and its steps' reserved
// pipeline time is what each ray type kept it busy. Untimed (functional), a unit is
// busy for its work / throughput and idle for the rest of the estimate.
// `queued_ist`: the level models the IST queue that holds leaves back (cycle).
void unit_figures(const std::vector<const TrvUnit*>& trv, const std::vector<const IstUnit*>& ist,
                  const std::vector<const ShadingUnit*>& shading, bool timed, bool queued_ist,
                  const HardwareConfig& c, uint64_t total_ps,
                  const std::array<CounterTotals, kRayTypeCount>& per_type, MachineFigures& f) {
  const double cycle_ps = c.clock_period_ps();
  const auto untimed = [&](uint64_t work, double per_cycle) {
    const uint64_t busy = std::min(total_ps, uint64_t(std::llround(double(work) / per_cycle * cycle_ps)));
    CycleSplit split{};
    split[size_t(CycleBucket::Busy)] = busy;
    split[size_t(CycleBucket::Idle)] = total_ps - busy;
    return split;
  };
  const auto busy_ps = [&](uint64_t work, double per_cycle) {
    return uint64_t(std::llround(double(work) / per_cycle * cycle_ps));
  };
  for (const TrvUnit* u : trv) {
    f.trv_passes.push_back(u->passes);
    f.trv.push_back(timed ? u->accounting.ps() : untimed(u->passes, c.trv_nodes_per_cycle));
    if (queued_ist) f.trv_leaves_blocked.push_back(u->leaves_blocked);
    for (size_t t = 0; timed && t < kRayTypeCount; ++t) {
      f.trv_busy_ps_by_type[t] += u->busy_ps_by_type[t];
      f.ray_ps_by_type[t] += u->ray_ps_by_type[t];
    }
  }
  for (const IstUnit* u : ist) {
    f.ist_tests.push_back(u->tests);
    f.anyhit_tests.push_back(u->anyhit_tests);
    if (timed) {
      f.ist.push_back(u->accounting.ps());
      for (size_t t = 0; t < kRayTypeCount; ++t) f.ist_busy_ps_by_type[t] += u->busy_ps_by_type[t];
      continue;
    }
    // The any-hit stage issues into the IST pipeline: its tests add to the unit's busy time.
    CycleSplit split = untimed(u->tests, c.ist_tests_per_cycle);
    if (f.anyhit) {
      const uint64_t more = std::min(split[size_t(CycleBucket::Idle)], busy_ps(u->anyhit_tests, c.anyhit_tests_per_cycle));
      split[size_t(CycleBucket::Busy)] += more;
      split[size_t(CycleBucket::Idle)] -= more;
    }
    f.ist.push_back(split);
  }
  for (const ShadingUnit* u : shading) {
    f.shading.push_back(timed ? u->accounting.ps() : untimed(u->shaded, c.shading_rays_per_cycle));
    f.shaded.push_back(u->shaded);
    f.spawned.push_back(u->spawned);
  }
  if (timed) return;
  for (size_t t = 0; t < kRayTypeCount; ++t) {
    uint64_t passes = 0, tests = 0;
    for (const TrvUnit* u : trv) passes += u->passes_by_type[t];
    for (const IstUnit* u : ist) tests += u->tests_by_type[t];
    f.trv_busy_ps_by_type[t] = busy_ps(passes, c.trv_nodes_per_cycle);
    // The any-hit stage's tests take the IST pipeline too (as the timed levels count them).
    f.ist_busy_ps_by_type[t] = busy_ps(tests, c.ist_tests_per_cycle) +
                               busy_ps(per_type[t].anyhit_tests, c.anyhit_tests_per_cycle);
  }
}

// The engine's units (functional and lt).
void engine_figures(RayEngine& engine, bool timed, const HardwareConfig& c, uint64_t total_ps,
                    MachineFigures& f) {
  f.anyhit = engine.anyhit_stage();
  for (Stage* stage : engine.dispatcher().stages()) {
    f.stages.push_back(stage);
    if (timed) f.stage_cycles.push_back(stage->finish_accounting(engine.end_ps()));
  }
  unit_figures(pointers_to(engine.trv_units()), pointers_to(engine.ist_units()),
               pointers_to(engine.shading_units()), timed, false, c, total_ps, engine.per_type(), f);
}

// Connects the request's traces, if any, to the level's DRAM model and caches.
void attach_traces(const SimulationRequest& request, DramModel& dram,
                   const std::vector<CacheModel*>& l1_node, const std::vector<CacheModel*>& l1_triangle,
                   const std::vector<CacheModel*>& l2) {
  if (DramTraceWriter* t = request.dram_trace)
    dram.set_request_observer([t](const DramRequestRecord& r) { t->write(r); });
  if (CacheTraceWriter* t = request.cache_trace) {
    const std::vector<CacheModel*>& caches =
        t->cache() == "l1_node" ? l1_node : t->cache() == "l1_triangle" ? l1_triangle : l2;
    t->header(caches.front()->config(), uint32_t(caches.size()));
    for (size_t i = 0; i < caches.size(); ++i)
      caches[i]->set_access_observer([t, i](const LineAccess& a, CacheModel::Outcome o) {
        t->write(uint32_t(i), a, o);
      });
  }
}

template <typename Owner>
std::vector<CacheModel*> models_of(const std::vector<std::unique_ptr<Owner>>& caches) {
  std::vector<CacheModel*> out;
  for (auto& c : caches) {
    if constexpr (std::is_same_v<Owner, CacheModel>) out.push_back(c.get());
    else out.push_back(&c->model);
  }
  return out;
}

void run_functional(const SimulationRequest& request, const HardwareConfig& config, const Workload& work,
                    const Progress& progress, const std::function<void()>& stop_clock,
                    SimulationResult& result) {
  FunctionalMemory memory(config, work.context->image().has_alpha_data());
  attach_traces(request, memory.dram, models_of(memory.l1_node), models_of(memory.l1_triangle),
                models_of(memory.l2));
  RayEngine engine(config, work, false);
  engine.run(
      memory, [](uint64_t) {},
      [&](bool last) {
        const auto& d = memory.dram.counters();
        result.frame_history.push_back({engine.total().rays, d.bytes, d.bytes_written, 0});
        if (!last) memory.reset_counters();
      },
      progress);
  stop_clock();
  result.per_type = engine.per_type();
  const CounterTotals total = engine.total();
  result.rays = total.rays;
  StatsRegistry& s = result.stats;
  const MachineShape& m = memory.shape;
  const double cycle_ps = config.clock_period_ps();
  // Analytic estimate: the busiest resource bounds the run.
  const double bytes_per_cycle = memory.dram.peak_bytes_per_second() * cycle_ps * 1e-12;
  const uint64_t dram_bytes = memory.dram.counters().bytes;
  uint64_t trv_passes = 0;
  for (const TrvUnit& u : engine.trv_units()) trv_passes += u.passes;
  const double trv_cycles = double(trv_passes) / (m.trv_units() * config.trv_nodes_per_cycle);
  // The any-hit stage shares the IST pipeline (zero tests on an opaque scene).
  const double ist_cycles = double(total.ist_ops) / (m.ist_units() * config.ist_tests_per_cycle) +
                            double(total.anyhit_tests) / (m.ist_units() * config.anyhit_tests_per_cycle);
  const double dram_cycles = double(dram_bytes) / bytes_per_cycle;
  const double cycles = std::max({trv_cycles, ist_cycles,
                                  double(total.rays) / (m.cores * config.raygen_rays_per_cycle),
                                  dram_cycles});
  result.simulated_ps = uint64_t(std::llround(std::ceil(cycles) * cycle_ps));
  s.set_real("time.bound_trv_cycles", trv_cycles, "cycles", "box-test pipeline passes / TRV throughput");
  s.set_real("time.bound_ist_cycles", ist_cycles, "cycles", "IST ops / IST throughput");
  s.set_real("time.bound_dram_cycles", dram_cycles, "cycles",
             "DRAM bytes read / peak DRAM bytes per cycle");
  MachineFigures f;
  engine_figures(engine, false, config, result.simulated_ps, f);
  for (auto& c : memory.l1_node) f.l1_node.push_back(c.get());
  for (auto& c : memory.l1_triangle) f.l1_triangle.push_back(c.get());
  for (auto& c : memory.l1_texture) f.l1_texture.push_back(c.get());
  for (auto& c : memory.l2) f.l2.push_back(c.get());
  f.dram = &memory.dram;
  f.noc = &memory.noc;
  report_machine(s, config, m, f, result.per_type, result.simulated_ps, false);
}

void run_lt(const SimulationRequest& request, const HardwareConfig& config, const Workload& work,
            const Progress& progress, const std::function<void()>& stop_clock, SimulationResult& result) {
  LtSystem lt("lt", config, work, progress);
  if (!config.accounted()) {
    for (TrvUnit& u : lt.engine.trv_units()) u.accounting.switch_off();
    for (IstUnit& u : lt.engine.ist_units()) u.accounting.switch_off();
    for (ShadingUnit& u : lt.engine.shading_units()) u.accounting.switch_off();
    for (Stage* stage : lt.engine.dispatcher().stages()) stage->switch_off_accounting();
  }
  if (work.timeline) {
    RayEngine& e = lt.engine;
    const auto pointers = [](auto& units) {
      std::vector<UnitAccounting*> out;
      for (auto& u : units) out.push_back(&u.accounting);
      return out;
    };
    const auto caches = [](std::vector<std::unique_ptr<LtCache>>& v) {
      std::vector<LtCache*> out;
      for (auto& c : v) out.push_back(c.get());
      return out;
    };
    draw_machine(*work.timeline, config, lt.shape, pointers(e.trv_units()), pointers(e.ist_units()),
                 pointers(e.shading_units()), e.dispatcher(), caches(lt.l1_node), caches(lt.l1_triangle),
                 caches(lt.l1_texture), caches(lt.l2),
                 lt.noc_model, lt.dram->model);
  }
  attach_traces(request, lt.dram->model, models_of(lt.l1_node), models_of(lt.l1_triangle),
                models_of(lt.l2));
  sc_core::sc_start();
  stop_clock();
  RayEngine& engine = lt.engine;
  result.frame_history = lt.frame_history;
  result.per_type = engine.per_type();
  result.rays = engine.total().rays;
  result.simulated_ps = engine.end_ps() - engine.start_ps();
  result.frame_start_ps = engine.start_ps();
  lt.dram->model.settle(engine.end_ps());  // idle-time refreshes into the counts
  MachineFigures f;
  engine_figures(engine, true, config, result.simulated_ps, f);
  for (auto& c : lt.l1_node) f.l1_node.push_back(&c->model);
  for (auto& c : lt.l1_triangle) f.l1_triangle.push_back(&c->model);
  for (auto& c : lt.l1_texture) f.l1_texture.push_back(&c->model);
  for (auto& c : lt.l2) f.l2.push_back(&c->model);
  f.dram = &lt.dram->model;
  f.noc = &lt.noc_model;
  report_machine(result.stats, config, lt.shape, f, result.per_type, result.simulated_ps, true);
}

void run_cycle(const SimulationRequest& request, const HardwareConfig& config, const Workload& work,
               const Progress& progress, const std::function<void()>& stop_clock,
               SimulationResult& result) {
  CycleSystem system("accelerator", config, work, progress);
  if (!config.accounted()) {
    for (auto& u : system.trv) u->model.accounting.switch_off();
    for (auto& u : system.ist) u->model.accounting.switch_off();
    for (auto& u : system.shading) u->model.accounting.switch_off();
    for (Stage* stage : system.dispatcher.stages()) stage->switch_off_accounting();
  }
  if (work.timeline) {
    std::vector<UnitAccounting*> trv, ist, shading;
    for (auto& u : system.trv) trv.push_back(&u->model.accounting);
    for (auto& u : system.ist) ist.push_back(&u->model.accounting);
    for (auto& u : system.shading) shading.push_back(&u->model.accounting);
    const auto caches = [](std::vector<std::unique_ptr<CycleCache>>& v) {
      std::vector<CycleCache*> out;
      for (auto& c : v) out.push_back(c.get());
      return out;
    };
    draw_machine(*work.timeline, config, system.shape, trv, ist, shading, system.dispatcher, caches(system.l1_node),
                 caches(system.l1_triangle), caches(system.l1_texture), caches(system.l2), system.noc_model,
                 system.dram->model);
  }
  attach_traces(request, system.dram->model, models_of(system.l1_node), models_of(system.l1_triangle),
                models_of(system.l2));
  sc_core::sc_start();
  stop_clock();
  if (!system.finished)
    throw std::runtime_error("cycle model stopped with " +
                             std::to_string(system.issued() - system.rays_done) +
                             " rays unfinished");
  result.per_type = system.per_type;
  result.rays = system.rays_done;
  result.frame_history = system.frame_history;
  result.simulated_ps = system.end_ps - system.frame_start_ps;
  result.frame_start_ps = system.frame_start_ps;
  system.dram->settle(system.end_ps);  // idle-time refreshes (or the reference's counts)
  MachineFigures f;
  std::vector<const TrvUnit*> trv;
  std::vector<const IstUnit*> ist;
  std::vector<const ShadingUnit*> shading;
  for (auto& u : system.trv) u->model.accounting.finish(system.end_ps), trv.push_back(&u->model);
  for (auto& u : system.ist) u->model.accounting.finish(system.end_ps), ist.push_back(&u->model);
  for (auto& u : system.shading) u->model.accounting.finish(system.end_ps), shading.push_back(&u->model);
  f.anyhit = work.context->image().has_alpha_data();
  unit_figures(trv, ist, shading, true, true, config, result.simulated_ps, result.per_type, f);
  for (auto& r : system.raygen) f.raygen_blocked_ps.push_back(r->blocked_ps);
  for (auto& c : system.l1_node) f.l1_node.push_back(&c->model);
  for (auto& c : system.l1_triangle) f.l1_triangle.push_back(&c->model);
  for (auto& c : system.l1_texture) f.l1_texture.push_back(&c->model);
  for (auto& c : system.l2) {
    f.l2.push_back(&c->model);
    f.l2_downstream_stall_ps.push_back(c->downstream_stall_ps);
    f.l2_downstream_refusals.push_back(c->downstream_refusals);
  }
  f.dram = &system.dram->model;
  f.noc = &system.noc_model;
  for (Stage* stage : system.dispatcher.stages()) {
    f.stages.push_back(stage);
    f.stage_cycles.push_back(stage->finish_accounting(system.end_ps));
  }
  report_machine(result.stats, config, system.shape, f, result.per_type, result.simulated_ps, true);
}

}  // namespace

SimulationResult simulate(const SimulationRequest& request) {
  if (!request.scene || !request.bvh) throw InputError("simulate", "scene and BVH are required");
  if (request.rays.empty() && !request.camera)
    throw InputError("simulate", "a camera or a ray set is required");
  if (request.frames < 1 || request.frames > 1000) throw InputError("--frames", "must be 1..1000");
  const HardwareConfig& config = request.config;
  validate(config);
  if (config.dram.model == "dramsim3") {
    if (request.fidelity != Fidelity::Cycle)
      throw InputError("dram.model", "dramsim3 serves the cycle level only (--fidelity cycle)");
    if (!dramsim3_linked())
      throw InputError("dram.model",
                       "dramsim3: this rtsim was built without DRAMsim3 (configure with -DRTSIM_DRAMSIM3=DIR)");
    dramsim3_ini(config.dram, config.l2.line_bytes);  // throws when DRAMsim3 cannot express it
  }
  if (request.fidelity != Fidelity::Functional) {
    if (systemc_used())
      throw std::runtime_error("a SystemC fidelity level runs once per process (one elaboration)");
    systemc_used() = true;
  }

  const MemoryImage image(*request.scene, *request.bvh, memory_layout_for(config));
  const TraversalContext context(*request.scene, *request.bvh, image, traversal_config_for(config));

  Workload work;
  work.scene = request.scene;
  work.context = &context;
  work.settings = request.settings;
  work.width = request.settings.width;
  work.height = request.settings.height;
  work.frames = request.frames;
  work.observer = request.observer;
  work.timeline = request.timeline;
  if (request.timeline && request.fidelity == Fidelity::Functional)
    throw InputError("--timeline", "the functional level has no time to draw; use --fidelity lt or cycle");
  if (request.timeline && !request.config.accounted())
    throw InputError("--timeline", "draws the cycle accounting, which stats.accounting = \"off\" turns off; "
                                   "turn it on or leave out --timeline");
  SimulationResult result;
  if (request.rays.empty()) {
    work.plan = plan_effects(*request.scene, request.settings);
    work.initial_rays = generate_primary_rays(*request.camera, request.settings);
    for (RayType t : kAllRayTypes)
      if (t != RayType::Primary && work.plan.on(t)) work.spawn_secondary = true;
  } else {
    work.initial_rays = request.rays;
  }
  result.plan = work.plan;
  std::optional<RayProbe> probe;
  if (request.trace_ray) {
    probe.emplace(find_target_ray(*request.trace_ray, context, request.camera, request.settings, work.plan,
                                  request.rays));
    work.probe = &*probe;
  }
  auto progress = request.progress ? request.progress : [](uint64_t) {};

  const double cpu_start = cpu_now();
  const auto start = std::chrono::steady_clock::now();
  const auto stop_clock = [&] {
    result.host_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.cpu_seconds = cpu_now() - cpu_start;
  };
  switch (request.fidelity) {
    case Fidelity::Functional: run_functional(request, config, work, progress, stop_clock, result); break;
    case Fidelity::Lt: run_lt(request, config, work, progress, stop_clock, result); break;
    case Fidelity::Cycle: run_cycle(request, config, work, progress, stop_clock, result); break;
  }
  StatsRegistry& s = result.stats;
  const double cycle_ps = config.clock_period_ps();
  report_time(s, config, result.simulated_ps, result.rays, request.frames);
  report_counts(s, result.per_type, image.has_alpha_data(), image.two_level());
  report_layout(s, image, request.scene->triangle_count());
  report_frames(s, result.frame_history, config, request.fidelity == Fidelity::Functional);
  result.cycles = uint64_t(std::llround(double(result.simulated_ps) / cycle_ps));
  result.peak_memory_bytes = peak_rss_bytes();
  if (probe)
    result.ray_trace = ray_trace_json(*probe, *request.trace_ray, image, context, cycle_ps, result.frame_start_ps,
                                      request.fidelity != Fidelity::Functional);
  return result;
}

std::string host_json(const SimulationResult& r) {
  nlohmann::json j;
  j["host_seconds"] = {{"value", r.host_seconds}, {"unit", "s"},
                       {"description", "wall time of the simulation (excluding loading and BVH build)"}};
  j["rays_per_host_second"] = {
      {"value", r.host_seconds > 0 ? double(r.rays) / r.host_seconds : 0.0},
      {"unit", "rays/s"},
      {"description", "simulated rays per host second"}};
  j["cpu_seconds"] = {{"value", r.cpu_seconds}, {"unit", "s"},
                      {"description", "CPU time of the simulation (one thread)"}};
  j["rays_per_cpu_second"] = {
      {"value", r.cpu_seconds > 0 ? double(r.rays) / r.cpu_seconds : 0.0},
      {"unit", "rays/s"},
      {"description", "simulated rays per CPU second (time other processes run is not counted, but their share of the host's caches and memory still slows it: on a busy host it varies by 10% or more; compare runs taken in turn)"}};
  j["peak_memory"] = {{"value", r.peak_memory_bytes}, {"unit", "bytes"},
                      {"description", "peak resident set size of the process"}};
  return j.dump(2) + "\n";
}

}  // namespace rtsim::sim
