// Invariants across fidelity levels: TRV/IST ops and node/triangle fetches are
// identical at functional, lt and cycle; cache and DRAM counts and bytes are
// identical between functional and lt. lt and cycle run in child processes
// (one SystemC elaboration per process).
#include "sim_test_support.h"

#include <gtest/gtest.h>

using namespace rtsim;
using namespace rtsim::sim;
using namespace rtsim::sim::test;

namespace {

std::map<std::string, double> run(const SmallWorkload& w, Fidelity level) {
  auto request = w.request(level);
  if (level == Fidelity::Functional) return flat_stats(simulate(request).stats.to_json());
  return flat_stats(in_child([&] { return simulate(request).stats.to_json(); }));
}

const char* kOpsAndFetches[] = {"ops.trv",          "ops.ist",         "ops.box_tests",
                                "fetches.node",     "fetches.triangle", "fetches.prim_ref",
                                "rays.total",       "per_type.ao.rays", "per_type.primary.trv_ops",
                                "per_type.ao.ist_ops", "stack.overflows"};

}  // namespace

TEST(SimLevels, OpsAndFetchesAgreeAtAllThreeLevels) {
  SmallWorkload w;
  const auto functional = run(w, Fidelity::Functional);
  const auto lt = run(w, Fidelity::Lt);
  const auto cycle = run(w, Fidelity::Cycle);
  ASSERT_GT(functional.at("ops.trv"), 0);
  ASSERT_GT(functional.at("per_type.ao.rays"), 0);
  for (const char* key : kOpsAndFetches) {
    ASSERT_TRUE(functional.count(key)) << key;
    EXPECT_EQ(functional.at(key), lt.at(key)) << key;
    EXPECT_EQ(functional.at(key), cycle.at(key)) << key;
  }
  // Time differs, and the timed levels report it.
  EXPECT_GT(lt.at("time.cycles"), 0);
  EXPECT_GT(cycle.at("time.cycles"), 0);
  EXPECT_TRUE(cycle.count("dram.row_hits"));
}

TEST(SimLevels, CacheAndDramCountsAgreeBetweenFunctionalAndLt) {
  SmallWorkload w;
  const auto functional = run(w, Fidelity::Functional);
  const auto lt = run(w, Fidelity::Lt);
  size_t compared = 0;
  for (const auto& [key, value] : functional) {
    const bool memory = key.rfind("l1_", 0) == 0 || key.rfind("l2.", 0) == 0 ||
                        key == "dram.reads" || key == "dram.bytes" ||
                        key.rfind("dram.bytes_by_type", 0) == 0;
    if (!memory) continue;
    ASSERT_TRUE(lt.count(key)) << key;
    EXPECT_EQ(value, lt.at(key)) << key;
    ++compared;
  }
  EXPECT_GT(compared, 20u);
  EXPECT_GT(functional.at("dram.bytes"), 0);
}

TEST(SimLevels, ShadingIsNotElaboratedForARayReplay) {
  SmallWorkload w;
  auto request = w.request(Fidelity::Cycle, 16, 0);
  request.rays = generate_primary_rays(*request.camera, request.settings);
  const auto stats = flat_stats(in_child([&] { return simulate(request).stats.to_json(); }));
  EXPECT_EQ(stats.at("rays.total"), 16.0 * 16.0);
  for (const auto& [key, value] : stats) EXPECT_NE(key.rfind("shading", 0), 0u) << key;
}

TEST(SimLevels, SecondSystemCRunInOneProcessIsRefused) {
  SmallWorkload w;
  const std::string out = in_child([&] {
    simulate(w.request(Fidelity::Cycle, 4, 0));
    try {
      simulate(w.request(Fidelity::Lt, 4, 0));
    } catch (const std::runtime_error& e) {
      return std::string("refused: ") + e.what();
    }
    return std::string("ran twice");
  });
  EXPECT_EQ(out.rfind("refused", 0), 0u) << out;
}

TEST(SimLevels, BackPressureDelaysButKeepsCountsExact) {
  // One MSHR per cache, one IST queue entry, one DRAM queue entry per channel:
  // every queue fills, the run still finishes with the functional counts.
  SmallWorkload w;
  auto tight = [&](Fidelity level) {
    auto r = w.request(level);
    r.config.l1_node.mshrs = r.config.l1_triangle.mshrs = r.config.l2.mshrs = 1;
    r.config.ist_queue_entries = 1;
    r.config.dram.queue_entries = 1;
    r.config.l2.size_bytes = 4096;  // force DRAM traffic
    return r;
  };
  const auto functional = flat_stats(simulate(tight(Fidelity::Functional)).stats.to_json());
  const auto cycle = flat_stats(in_child([&] { return simulate(tight(Fidelity::Cycle)).stats.to_json(); }));
  for (const char* key : kOpsAndFetches) EXPECT_EQ(functional.at(key), cycle.at(key)) << key;
  EXPECT_GT(cycle.at("l1_node.all.mshr_full_stalls") + cycle.at("l1_triangle.all.mshr_full_stalls"), 0);
  EXPECT_GT(cycle.at("ist.unit0.stalled_cycles") + cycle.at("trv.unit0.stalled_cycles"), 0);
  EXPECT_GT(cycle.at("dram.reads"), 0);
  // Tighter resources cannot make the same work faster.
  const auto roomy = flat_stats(in_child([&] { return simulate(w.request(Fidelity::Cycle)).stats.to_json(); }));
  EXPECT_GT(cycle.at("time.cycles"), roomy.at("time.cycles"));
}

TEST(SimLevels, FunctionalReportsUnitWorkAndAnEstimate) {
  SmallWorkload w;
  const auto s = flat_stats(simulate(w.request(Fidelity::Functional)).stats.to_json());
  double nodes = 0;
  for (uint32_t u = 0; u < preset("mobile").trv_units; ++u)
    nodes += s.at("trv.unit" + std::to_string(u) + ".nodes");
  EXPECT_EQ(nodes, s.at("ops.trv"));
  EXPECT_GE(s.at("time.cycles"), s.at("time.bound_trv_cycles"));
  EXPECT_GE(s.at("time.cycles"), s.at("time.bound_dram_cycles"));
}
