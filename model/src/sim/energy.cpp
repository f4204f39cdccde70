#include <rtsim/model/sim/energy.h>

#include <iterator>
#include <string>

namespace rtsim::sim {

namespace {

// Each ray type's share of a matrix's bytes (all zero when it is empty).
std::array<double, kRayTypeCount> shares(const TrafficMatrix& m) {
  std::array<double, kRayTypeCount> out{};
  const double total = double(m.total());
  if (total <= 0) return out;
  for (size_t t = 0; t < kRayTypeCount; ++t) {
    uint64_t bytes = 0;
    for (uint64_t b : m.bytes[t]) bytes += b;
    out[t] = double(bytes) / total;
  }
  return out;
}

}  // namespace

void report_energy(StatsRegistry& s, const HardwareConfig& config, const EnergyCounts& c) {
  const EnergyConfig& e = config.energy;
  const DramConfig& d = config.dram;
  struct Component {
    const char* name;
    double pj;
    std::array<double, kRayTypeCount> share;
    const char* what;
  };
  std::array<double, kRayTypeCount> trv_share{}, ist_share{};
  uint64_t box_tests = 0, triangle_tests = 0, rays = 0;
  for (const CounterTotals& t : c.per_type)
    box_tests += t.box_tests, triangle_tests += t.ist_ops, rays += t.rays;
  for (size_t t = 0; t < kRayTypeCount; ++t) {
    trv_share[t] = box_tests ? double(c.per_type[t].box_tests) / double(box_tests) : 0;
    ist_share[t] = triangle_tests ? double(c.per_type[t].ist_ops) / double(triangle_tests) : 0;
  }
  // The on-chip energies are the 65 nm machine's (the crossbar's figure, measured at
  // 45 nm, stands in for it there as before); the process node scales them all, never
  // the DRAM, which is its own chip.
  const double at65 = process_energy_factor(65, e.process_nm, e.vdd);
  const double sram = e.sram_scale * at65;
  s.set_real("energy.process_nm", e.process_nm, "nm", "process node the on-chip energies are scaled to");
  s.set_real("energy.process_factor", at65, "ratio",
             "energy at energy.process_nm / at 65 nm (Stillmaker and Baas 2017), on units, caches and crossbar");
  const double dram_pj = double(c.dram_activates) * d.activate_pj +
                         double(c.dram_read_bursts) * d.read_burst_pj +
                         double(c.dram_write_bursts) * d.write_burst_pj +
                         double(c.dram_refreshes) * d.refresh_pj;
  // In kEnergyComponents' order, under its names.
  const Component parts[] = {
      {kEnergyComponents[0], double(box_tests) * e.box_test_pj * at65, trv_share, "TRV ray-box tests"},
      {kEnergyComponents[1], double(triangle_tests) * e.triangle_test_pj * at65, ist_share,
       "IST ray-triangle tests"},
      {kEnergyComponents[2], c.l1_node_pj * sram, shares(c.l1_node_bytes),
       "L1 node cache accesses (requests and write-backs)"},
      {kEnergyComponents[3], c.l1_triangle_pj * sram, shares(c.l1_triangle_bytes),
       "L1 triangle cache accesses (requests and write-backs)"},
      {kEnergyComponents[4], c.l2_pj * sram, shares(c.l2_bytes), "L2 accesses (requests and write-backs)"},
      {kEnergyComponents[5], double(c.noc_bytes) * e.noc_byte_pj * at65, shares(c.l2_bytes),
       "bytes through the crossbar"},
      {kEnergyComponents[6], dram_pj, shares(c.dram_bytes), "DRAM activates, read and write bursts, refreshes"},
  };
  static_assert(std::size(parts) == kEnergyComponents.size());
  double total = 0;
  std::array<double, kRayTypeCount> by_type{};
  for (const Component& p : parts) {
    s.set_real(std::string("energy.") + p.name + ".pj", p.pj, "pJ", std::string("energy of ") + p.what);
    s.set_real(std::string("energy.") + p.name + ".pj_per_ray", rays ? p.pj / double(rays) : 0,
               "pJ/ray", std::string("energy of ") + p.what + " / rays");
    total += p.pj;
    for (size_t t = 0; t < kRayTypeCount; ++t) by_type[t] += p.pj * p.share[t];
  }
  // The stages, only where built (a run without them keeps its stats).
  const EnergyPrices prices{e, at65, sram};
  for (const Stage* stage : c.stages) {
    const StageEnergy part = stage->energy(config, prices);
    const std::string name = std::string("energy.") + stage->traits().name;
    s.set_real(name + ".pj", part.pj, "pJ", "energy of " + part.what);
    s.set_real(name + ".pj_per_ray", rays ? part.pj / double(rays) : 0, "pJ/ray",
               "energy of " + part.what_per_ray + " / rays");
    total += part.pj;
    double caused = 0;
    for (double v : part.caused) caused += v;
    for (size_t t = 0; t < kRayTypeCount; ++t)
      if (caused > 0) by_type[t] += part.pj * part.caused[t] / caused;
  }
  // The instance transforms (instanced scenes: a run whose rays entered instances).
  uint64_t transforms = 0;
  for (const CounterTotals& t : c.per_type) transforms += t.xfm_ops;
  if (transforms) {
    const double pj = double(transforms) * e.xfm_pj * at65;
    s.set_real("energy.xfm.pj", pj, "pJ", "energy of the TRV units' instance transforms (XFM ops)");
    s.set_real("energy.xfm.pj_per_ray", rays ? pj / double(rays) : 0, "pJ/ray",
               "energy of the TRV units' instance transforms / rays");
    total += pj;
    for (size_t t = 0; t < kRayTypeCount; ++t) by_type[t] += pj * double(c.per_type[t].xfm_ops) / double(transforms);
  }
  // The any-hit stages and their texture caches, only where built (alpha-tested scenes).
  if (c.anyhit_built) {
    uint64_t tests = 0;
    for (const CounterTotals& t : c.per_type) tests += t.anyhit_tests;
    const double stage_pj = double(tests) * e.anyhit_test_pj * at65;
    const double cache_pj = c.l1_texture_pj * sram;
    s.set_real("energy.anyhit.pj", stage_pj, "pJ", "energy of the any-hit stages' alpha tests");
    s.set_real("energy.anyhit.pj_per_ray", rays ? stage_pj / double(rays) : 0, "pJ/ray",
               "energy of the any-hit stages' alpha tests / rays");
    s.set_real("energy.l1_texture.pj", cache_pj, "pJ",
               "energy of L1 texture cache accesses (requests and write-backs)");
    s.set_real("energy.l1_texture.pj_per_ray", rays ? cache_pj / double(rays) : 0, "pJ/ray",
               "energy of L1 texture cache accesses / rays");
    total += stage_pj + cache_pj;
    const std::array<double, kRayTypeCount> cache_share = shares(c.l1_texture_bytes);
    for (size_t t = 0; t < kRayTypeCount; ++t) {
      if (tests) by_type[t] += stage_pj * double(c.per_type[t].anyhit_tests) / double(tests);
      by_type[t] += cache_pj * cache_share[t];
    }
  }
  s.set_real("energy.total_pj", total, "pJ", "dynamic energy of the run (no leakage, no DRAM background)");
  s.set_real("energy.pj_per_ray", rays ? total / double(rays) : 0, "pJ/ray", "energy.total_pj / rays");
  s.set_real("energy.rays_per_joule", total > 0 ? double(rays) / (total * 1e-12) : 0, "rays/J",
             "rays / dynamic energy");
  s.set_real("energy.dram_share", total > 0 ? dram_pj / total : 0, "ratio", "DRAM energy / total");
  s.set_real("energy.dram_background.pj", c.dram_background_pj, "pJ",
             "DRAM standby energy over the run (dram.background_mw x channels x simulated time), "
             "not in total_pj");
  s.set_real("energy.dram_background.pj_per_ray", rays ? c.dram_background_pj / double(rays) : 0,
             "pJ/ray", "DRAM standby energy / rays");
  s.set_real("energy.pj_per_ray_with_background",
             rays ? (total + c.dram_background_pj) / double(rays) : 0, "pJ/ray",
             "dynamic energy and the DRAM's standby energy / rays");
  for (RayType t : kAllRayTypes) {
    const CounterTotals& c_t = c.per_type[size_t(t)];
    if (c_t.rays == 0) continue;
    s.set_real(std::string("energy.per_type.") + ray_type_name(t) + ".pj_per_ray",
               by_type[size_t(t)] / double(c_t.rays), "pJ/ray",
               std::string("energy shared out to ") + ray_type_name(t) +
                   " rays (by their bytes or ops at each component) / their count");
  }
}

}  // namespace rtsim::sim
