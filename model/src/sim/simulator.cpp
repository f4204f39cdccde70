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

struct UnitFigures {
  uint64_t busy_ps = 0, occupied_ps = 0, stalled_ps = 0;
};

void report_unit(StatsRegistry& s, const std::string& prefix, const UnitFigures& f,
                 uint64_t total_ps, double cycle_ps, uint64_t work, const std::string& work_unit,
                 const std::string& work_description) {
  const auto cycles = [&](uint64_t ps) { return uint64_t(std::llround(double(ps) / cycle_ps)); };
  const uint64_t total = cycles(total_ps);
  const uint64_t busy = std::min(cycles(f.busy_ps), total);
  const uint64_t occupied = std::min(cycles(f.occupied_ps), total);
  const uint64_t stalled = std::min(cycles(f.stalled_ps), occupied);
  s.set(prefix + ".busy_cycles", busy, "cycles", "cycles the unit's pipeline accepted work");
  s.set(prefix + ".idle_cycles", total - occupied, "cycles", "cycles with no work resident");
  s.set(prefix + ".stalled_cycles", stalled, "cycles",
        "cycles resident work waited for a full downstream queue");
  s.set(prefix + ".waiting_cycles", occupied - std::min(occupied, busy), "cycles",
        "cycles with work resident but the pipeline not fed (memory latency, stalls)");
  s.set_real(prefix + ".utilisation", total ? double(busy) / double(total) : 0, "ratio",
             "busy cycles / simulated cycles");
  s.set(prefix + "." + work_unit, work, work_unit, work_description);
}

void report_counts(StatsRegistry& s, const std::array<CounterTotals, kRayTypeCount>& per_type) {
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
  }
}

// What one run of any level leaves to report, per instance of the machine
// (machine.h numbering). Each level fills it from its own components; the names
// and the accounting are this one function's.
struct MachineFigures {
  std::vector<UnitFigures> trv, ist;          // per TRV / IST unit
  std::vector<uint64_t> trv_passes, ist_tests;
  std::vector<UnitFigures> shading;           // per core; empty when nothing is shaded
  std::vector<uint64_t> shaded, spawned;      // per core
  std::vector<uint64_t> raygen_stalled_ps;    // per core (cycle level only)
  std::vector<const CacheModel*> l1_node, l1_triangle, l2;
  std::vector<uint64_t> l2_downstream_stall_ps, l2_downstream_refusals;  // per slice (cycle)
  const DramModel* dram = nullptr;
  const Crossbar* noc = nullptr;
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
  level(f.l2, e.l2_pj, e.l2_bytes);
  e.dram_bytes = dram_bytes;
  e.noc_bytes = f.noc->bytes();
  const DramModel::Counters& d = f.dram->counters();
  e.dram_activates = d.activates;
  e.dram_read_bursts = (d.bytes + dram.burst_bytes - 1) / dram.burst_bytes;
  e.dram_write_bursts = (d.bytes_written + dram.burst_bytes - 1) / dram.burst_bytes;
  e.dram_refreshes = d.refreshes;
  e.per_type = per_type;
  return e;
}

void report_machine(StatsRegistry& s, const HardwareConfig& config, const MachineShape& m,
                    const MachineFigures& f, const std::array<CounterTotals, kRayTypeCount>& per_type,
                    uint64_t sim_ps, bool timed) {
  const double cycle_ps = config.clock_period_ps();
  uint64_t rays = 0;
  for (const CounterTotals& t : per_type) rays += t.rays;
  const auto cycles = [&](uint64_t ps) { return uint64_t(std::llround(double(ps) / cycle_ps)); };
  for (uint32_t u = 0; u < f.trv.size(); ++u)
    report_unit(s, m.trv_name(u), f.trv[u], sim_ps, cycle_ps, f.trv_passes[u], "passes",
                "box-test pipeline passes (a node takes ceil(children / trv.boxes_per_pass))");
  for (uint32_t u = 0; u < f.ist.size(); ++u)
    report_unit(s, m.ist_name(u), f.ist[u], sim_ps, cycle_ps, f.ist_tests[u], "tests",
                "triangle tests through the pipeline");
  for (uint32_t c = 0; c < f.shading.size(); ++c) {
    const std::string p = MachineShape::core_name(c) + ".shading";
    report_unit(s, p, f.shading[c], sim_ps, cycle_ps, f.shaded[c], "rays", "rays shaded");
    s.set(p + ".spawned", f.spawned[c], "rays", "secondary rays spawned");
  }
  for (uint32_t c = 0; c < f.raygen_stalled_ps.size(); ++c)
    s.set(MachineShape::core_name(c) + ".raygen.stalled_cycles", cycles(f.raygen_stalled_ps[c]),
          "cycles", "cycles a ready ray found no free TRV slot of its core");
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
  filled.report(s, "dram.bytes_by_type", "bytes read from DRAM");
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
  s.set("memory.total_bytes", f.total_bytes(), "bytes", "footprint of the BVH and its triangles");
  s.set_real("memory.bytes_per_triangle", triangles ? double(f.total_bytes()) / double(triangles) : 0,
             "bytes/triangle", "footprint / scene triangles");
}

void report_time(StatsRegistry& s, const HardwareConfig& c, uint64_t sim_ps, uint64_t rays,
                 bool estimate, uint32_t frames) {
  const double cycle_ps = c.clock_period_ps();
  const uint64_t cycles = uint64_t(std::llround(double(sim_ps) / cycle_ps));
  const std::string how = estimate ? " (analytic estimate)" : "";
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
    const std::string p = "frames.frame" + std::to_string(f + 1);
    const std::string which = f == 0 ? " (cold caches)" : "";
    s.set(p + ".dram_bytes", h.dram_bytes_read, "bytes", "bytes read from DRAM in this frame" + which);
    s.set(p + ".dram_bytes_written", h.dram_bytes_written, "bytes", "bytes written to DRAM in this frame");
    s.set_real(p + ".dram_bytes_per_ray", h.rays ? double(h.dram_bytes_read) / double(h.rays) : 0,
               "bytes/ray", "DRAM bytes read / rays in this frame" + which);
    if (!untimed)
      s.set(p + ".cycles", uint64_t(std::llround(double(h.simulated_ps) / c.clock_period_ps())),
            "cycles", "simulated cycles of this frame" + which);
  }
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

// Figures of the engine's units (functional and lt). Untimed, a unit is busy for
// its work / throughput and idle for the rest of the estimate; stalls are not
// modelled at this level.
void engine_figures(const RayEngine& engine, bool timed, const HardwareConfig& c, MachineFigures& f) {
  const double cycle_ps = c.clock_period_ps();
  const auto units = [&](const std::vector<uint64_t>& work, const std::vector<UnitTime>& time,
                         double per_cycle, std::vector<UnitFigures>& out) {
    for (size_t u = 0; u < work.size(); ++u) {
      const uint64_t busy = uint64_t(std::llround(double(work[u]) / per_cycle * cycle_ps));
      out.push_back(timed ? UnitFigures{time[u].busy_ps, time[u].occupied_ps(), 0}
                          : UnitFigures{busy, busy, 0});
    }
  };
  f.trv_passes = engine.trv_passes();
  f.ist_tests = engine.ist_tests();
  units(f.trv_passes, engine.trv_time(), c.trv_nodes_per_cycle, f.trv);
  units(f.ist_tests, engine.ist_time(), c.ist_tests_per_cycle, f.ist);
  f.shaded = engine.shaded();
  f.spawned = engine.spawned();
  if (engine.spawned_rays_are_shaded())
    units(f.shaded, engine.shading_time(), c.shading_rays_per_cycle, f.shading);
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
  FunctionalMemory memory(config);
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
  for (uint64_t p : engine.trv_passes()) trv_passes += p;
  const double trv_cycles = double(trv_passes) / (m.trv_units() * config.trv_nodes_per_cycle);
  const double ist_cycles = double(total.ist_ops) / (m.ist_units() * config.ist_tests_per_cycle);
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
  engine_figures(engine, false, config, f);
  for (auto& c : memory.l1_node) f.l1_node.push_back(c.get());
  for (auto& c : memory.l1_triangle) f.l1_triangle.push_back(c.get());
  for (auto& c : memory.l2) f.l2.push_back(c.get());
  f.dram = &memory.dram;
  f.noc = &memory.noc;
  report_machine(s, config, m, f, result.per_type, result.simulated_ps, false);
}

void run_lt(const SimulationRequest& request, const HardwareConfig& config, const Workload& work,
            const Progress& progress, const std::function<void()>& stop_clock, SimulationResult& result) {
  LtSystem lt("lt", config, work, progress);
  attach_traces(request, lt.dram->model, models_of(lt.l1_node), models_of(lt.l1_triangle),
                models_of(lt.l2));
  sc_core::sc_start();
  stop_clock();
  const RayEngine& engine = lt.engine;
  result.frame_history = lt.frame_history;
  result.per_type = engine.per_type();
  result.rays = engine.total().rays;
  result.simulated_ps = engine.end_ps() - engine.start_ps();
  lt.dram->model.settle(engine.end_ps());  // idle-time refreshes into the counts
  MachineFigures f;
  engine_figures(engine, true, config, f);
  for (auto& c : lt.l1_node) f.l1_node.push_back(&c->model);
  for (auto& c : lt.l1_triangle) f.l1_triangle.push_back(&c->model);
  for (auto& c : lt.l2) f.l2.push_back(&c->model);
  f.dram = &lt.dram->model;
  f.noc = &lt.noc_model;
  report_machine(result.stats, config, lt.shape, f, result.per_type, result.simulated_ps, true);
}

void run_cycle(const SimulationRequest& request, const HardwareConfig& config, const Workload& work,
               const Progress& progress, const std::function<void()>& stop_clock,
               SimulationResult& result) {
  CycleSystem system("accelerator", config, work, progress);
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
  system.dram->settle(system.end_ps);  // idle-time refreshes (or the reference's counts)
  MachineFigures f;
  for (auto& u : system.trv) {
    const Occupancy& o = u->occupancy;
    f.trv.push_back({o.busy_ps, o.occupied_ps, o.stalled_ps});
    f.trv_passes.push_back(u->passes);
  }
  for (auto& u : system.ist) {
    const Occupancy& o = u->occupancy;
    f.ist.push_back({o.busy_ps, o.occupied_ps, o.stalled_ps});
    f.ist_tests.push_back(u->tests);
  }
  for (auto& sh : system.shading) {
    f.shading.push_back({sh->busy_ps, sh->occupancy.occupied_ps, 0});
    f.shaded.push_back(sh->shaded);
    f.spawned.push_back(sh->spawned);
  }
  for (auto& r : system.raygen) f.raygen_stalled_ps.push_back(r->stalled_ps);
  for (auto& c : system.l1_node) f.l1_node.push_back(&c->model);
  for (auto& c : system.l1_triangle) f.l1_triangle.push_back(&c->model);
  for (auto& c : system.l2) {
    f.l2.push_back(&c->model);
    f.l2_downstream_stall_ps.push_back(c->downstream_stall_ps);
    f.l2_downstream_refusals.push_back(c->downstream_refusals);
  }
  f.dram = &system.dram->model;
  f.noc = &system.noc_model;
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
  report_time(s, config, result.simulated_ps, result.rays, request.fidelity == Fidelity::Functional,
              request.frames);
  report_counts(s, result.per_type);
  report_layout(s, image, request.scene->triangle_count());
  report_frames(s, result.frame_history, config, request.fidelity == Fidelity::Functional);
  result.cycles = uint64_t(std::llround(double(result.simulated_ps) / cycle_ps));
  result.peak_memory_bytes = peak_rss_bytes();
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
