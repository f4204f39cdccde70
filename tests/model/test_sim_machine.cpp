// The machine's description (machine.h): instance numbering and names, L2 slices,
// the crossbar's port timing and counts.
#include <rtsim/model/core/cache_tags.h>
#include <rtsim/model/sim/machine.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

#include <set>

using namespace rtsim;
using namespace rtsim::sim;

TEST(SimMachine, UnitsAreNumberedCoreMajorAndNamedPerCore) {
  HardwareConfig c = preset("mobile");
  c.cores = 3, c.trv_units = 4, c.ist_units = 2;
  const MachineShape m = MachineShape::of(c);
  EXPECT_EQ(m.trv_units(), 12u);
  EXPECT_EQ(m.ist_units(), 6u);
  EXPECT_EQ(m.core_of_trv(5), 1u);
  EXPECT_EQ(m.trv_name(5), "core1.trv1");
  EXPECT_EQ(m.l1_node_name(11), "core2.l1_node3");
  // A TRV unit's leaves go to an IST unit of its own core.
  for (uint32_t u = 0; u < m.trv_units(); ++u) EXPECT_EQ(m.core_of_ist(m.ist_of_trv(u)), m.core_of_trv(u));
  EXPECT_EQ(m.ist_of_trv(6), 2u * 1 + (6 % 4) % 2);
  EXPECT_EQ(m.ist_name(m.ist_of_trv(6)), "core1.ist0");
  EXPECT_EQ(MachineShape::module_name("core1.trv0"), "core1_trv0");
}

TEST(SimMachine, SlicesInterleaveLinesAndUseAllTheirSets) {
  HardwareConfig c = preset("mobile");
  c.l2_slices = 4;
  const MachineShape m = MachineShape::of(c);
  std::set<uint32_t> seen;
  for (uint64_t line = 0; line < 8; ++line) seen.insert(m.slice_of(line * 64 + 5));
  EXPECT_EQ(seen.size(), 4u);
  EXPECT_EQ(m.slice_of(4 * 64), 0u);
  EXPECT_EQ(c.l2_slice().size_bytes, c.l2.size_bytes / 4);
  // A slice sees every 4th line: indexed by line / 4, one way per set holds one
  // line in each of its sets without an eviction.
  CacheTags slice({4 * 64, 64, 1, 4});
  for (uint64_t k = 0; k < 4; ++k) EXPECT_FALSE(slice.insert(k * 4 * 64).valid) << k;
  for (uint64_t k = 0; k < 4; ++k) EXPECT_TRUE(slice.contains(k * 4 * 64)) << k;
  CacheTags plain({4 * 64, 64, 1, 1});  // indexed by line: the same lines share one set
  plain.insert(0);
  EXPECT_TRUE(plain.insert(4 * 64).valid);
}

TEST(SimMachine, SliceGeometryIsCheckedPerSliceAndNamesTheKey) {
  HardwareConfig c = preset("mobile");
  c.l2.size_bytes = 3 * 1024 * 1024, c.l2.associativity = 16, c.l2_slices = 12;
  EXPECT_NO_THROW(validate(c));  // 256 KiB slices of 256 sets
  c.l2_slices = 5;
  try {
    validate(c);
    FAIL() << "5 slices of 3 MiB accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("l2.slices"), std::string::npos) << e.what();
  }
}

TEST(SimMachine, CrossbarSerialisesFlitsPerPortThenAddsItsLatency) {
  HardwareConfig c = preset("mobile");  // 1000 MHz: 1000 ps a cycle
  c.cores = 2, c.l2_slices = 2;
  c.noc_latency_cycles = 10, c.noc_flit_bytes = 32, c.noc_header_bytes = 8;
  Crossbar x(c, MachineShape::of(c), true);
  // A read request is its header: one flit, then the latency.
  EXPECT_EQ(x.to_slice(0, 1, 0, 0), 11000u);
  // A 64-byte line and its header are three flits.
  EXPECT_EQ(x.to_core(1, 0, 64, 20000), 20000u + 3000 + 10000);
  // A second answer to the same core at the same time waits for its port.
  EXPECT_EQ(x.to_core(0, 0, 64, 20000), 23000u + 3000 + 10000);
  // To another core: slice 0's outgoing port is taken from 23000 to 26000 by that
  // answer, but free now: no head-of-line blocking.
  EXPECT_EQ(x.to_core(0, 1, 64, 20000), 20000u + 3000 + 10000);
  EXPECT_EQ(x.to_core(1, 1, 64, 26000), 26000u + 3000 + 10000);
  // A reservation made ahead of time (an answer after a DRAM access, as the lt level
  // makes it) does not hold up one made later for an earlier time.
  EXPECT_EQ(x.to_core(1, 0, 64, 60000), 60000u + 3000 + 10000);
  EXPECT_EQ(x.to_core(1, 0, 64, 40000), 40000u + 3000 + 10000);
  EXPECT_EQ(x.to_core(0, 0, 64, 61000), 63000u + 3000 + 10000);  // core 0's port: 60000..63000
  StatsRegistry s;
  x.report(s, "noc", 100000);
  EXPECT_EQ(s.number("noc.to_slices.messages"), 1);
  EXPECT_EQ(s.number("noc.to_cores.messages"), 7);
  EXPECT_EQ(s.number("noc.to_cores.bytes"), 7 * 72);
  EXPECT_EQ(s.number("noc.to_cores.flits"), 21);
  EXPECT_DOUBLE_EQ(s.number("noc.to_cores.max_port_utilisation"), 15.0 / 100);  // core 0: 5 answers
  EXPECT_DOUBLE_EQ(s.number("noc.wait_cycles_max"), 3);
  EXPECT_DOUBLE_EQ(s.number("noc.wait_cycles_mean"), (3.0 + 2) / 8);
  // An ideal crossbar (flit_bytes 0) only adds its latency, and counts.
  c.noc_flit_bytes = 0;
  Crossbar ideal(c, MachineShape::of(c), true);
  EXPECT_EQ(ideal.to_core(0, 0, 64, 500), 10500u);
  EXPECT_EQ(ideal.to_core(0, 0, 64, 500), 10500u);
}

TEST(SimMachine, FunctionalHierarchyRoutesEachCoresMissesToTheLinesSlice) {
  HardwareConfig c = preset("mobile");
  c.cores = 2, c.trv_units = 1, c.ist_units = 1, c.l2_slices = 2;
  FunctionalMemory m(c);
  // Core 0's and core 1's TRV units each miss on two lines, one per slice.
  for (uint32_t unit : {0u, 1u})
    for (uint64_t line : {0u, 64u})
      m.access(Requester::Trv, unit, LineAccess{line, 64, AccessKind::Node, RayType::Primary, false}, 0);
  EXPECT_EQ(m.l2[0]->counters().accesses, 2u);
  EXPECT_EQ(m.l2[1]->counters().accesses, 2u);
  EXPECT_EQ(m.l2[0]->counters().hits, 1u);  // the second core finds the line the first brought
  EXPECT_EQ(m.dram.counters().bytes, 2u * 64);
  StatsRegistry s;
  m.noc.report(s, "noc", 0);
  EXPECT_EQ(s.number("noc.to_slices.messages"), 4);
  EXPECT_EQ(s.number("noc.to_cores.bytes"), 4 * (64 + c.noc_header_bytes));
}

// A core can have L1 caches of its own ([core.N] tables); everything else about the
// machine stays uniform. Bad per-core keys are refused, naming the key.
TEST(SimMachine, ACoreCanHaveItsOwnL1Caches) {
  const HardwareConfig c = parse_hardware_config(
      "cores = 2\n[core.1]\nl1_node.size_bytes = 1024\nl1_triangle.associativity = 2\n"
      "[l1_node]\nsize_bytes = 32768\n",
      "het.toml");
  EXPECT_EQ(c.l1_node_of(0).size_bytes, 32768u);
  EXPECT_EQ(c.l1_node_of(1).size_bytes, 1024u);  // the core's own, whatever the key order
  EXPECT_EQ(c.l1_triangle_of(1).associativity, 2u);
  EXPECT_EQ(c.l1_triangle_of(1).size_bytes, c.l1_triangle.size_bytes);
  EXPECT_NE(to_json(c).find("\"core\""), std::string::npos);
  FunctionalMemory m(c);
  EXPECT_EQ(m.l1_node[0]->config().size_bytes, 32768u);
  EXPECT_EQ(m.l1_node[c.trv_units]->config().size_bytes, 1024u);  // core 1's first TRV unit
  const auto error = [](const std::string& text) {
    try {
      parse_hardware_config(text, "bad.toml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("cores = 2\n[core.2]\nl1_node.size_bytes = 1024\n").find("core.2"), std::string::npos);
  EXPECT_NE(error("cores = 2\n[core.1]\nl1_node.line_bytes = 128\n").find("core.1.l1_node.line_bytes"),
            std::string::npos);
  EXPECT_NE(error("cores = 2\n[core.1]\ntrv.units = 2\n").find("per-core key"), std::string::npos);
  EXPECT_NE(error("cores = 2\n[core.one]\nl1_node.size_bytes = 1024\n").find("core.<N>"), std::string::npos);
  EXPECT_NE(error("cores = 2\n[core.1]\nl1_node.size_bytes = 1000\n").find("core.1.l1_node.size_bytes"),
            std::string::npos);
}
