// Invariants across fidelity levels: TRV/IST ops and node/triangle fetches are
// identical at functional, lt and cycle; every ray's access stream is the same at
// every level; with one ray in flight the three read the same DRAM bytes; lt does
// not depend on its quantum; frames replay with warm caches. lt and cycle run in
// child processes (one SystemC elaboration per process).
#include "sim_test_support.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <tuple>

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

namespace {
// Every access each ray issued, in order, as text (child processes hand it back).
std::string access_streams(SimulationRequest request) {
  // Rays by what they are: a spawned ray's index depends on when its parent finished.
  std::map<std::tuple<uint32_t, uint32_t, int, int, float, float, float>, std::string> per_ray;
  const uint64_t area_bytes = TraversalContext::kStackAreaEntries * request.config.trv_stack_entry_bytes;
  request.observer = [&](const Ray& ray, const MemoryAccess& a) {
    // A stack entry's address depends on the ray slot the ray ran in (a matter of
    // timing): compare its position within the slot's area.
    const uint64_t address = a.kind == AccessKind::Stack ? a.address % area_bytes : a.address;
    char line[96];
    std::snprintf(line, sizeof line, "%llx %u %d %d;", (unsigned long long)address, a.bytes,
                  int(a.kind), int(a.write));
    per_ray[{ray.pixel, ray.sample, int(ray.type), ray.bounce, ray.direction.x, ray.direction.y,
             ray.direction.z}] += line;
  };
  simulate(request);
  std::string out;
  for (const auto& [ray, stream] : per_ray)
    out += std::to_string(std::get<0>(ray)) + "/" + std::to_string(std::get<2>(ray)) + ":" + stream + "\n";
  return out;
}

SimulationRequest one_ray_in_flight(const SmallWorkload& w, Fidelity level) {
  auto r = w.request(level);
  r.config.trv_units = r.config.ist_units = 1;
  r.config.trv_ray_slots = 1;
  r.config.trv_stack_entries = 2;  // spills and refills: writes and write-backs too
  r.config.l2.size_bytes = 8192;   // DRAM traffic
  r.config.l1_node.size_bytes = r.config.l1_triangle.size_bytes = 1024;
  // Spawned rays after every primary: "behind" would let timing decide whether a
  // ray's AO rays (ready after shading) or the next primary ray go first.
  r.config.raygen_secondary = "after";
  return r;
}
}  // namespace

TEST(SimLevels, EveryRaysAccessStreamIsTheSameAtEveryLevel) {
  SmallWorkload w;
  auto request = [&](Fidelity level) {
    auto r = w.request(level);
    r.config.trv_stack_entries = 2;  // stack traffic in the streams
    return r;
  };
  const std::string functional = access_streams(request(Fidelity::Functional));
  const std::string lt = in_child([&] { return access_streams(request(Fidelity::Lt)); });
  const std::string cycle = in_child([&] { return access_streams(request(Fidelity::Cycle)); });
  ASSERT_GT(functional.size(), 10000u);
  EXPECT_NE(functional.find(" 3 1;"), std::string::npos) << "no stack spill in the streams";
  // Report the first ray whose stream differs, not the whole text.
  const auto first_difference = [](const std::string& a, const std::string& b) {
    size_t i = 0;
    while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
    const size_t line = a.rfind('\n', i) == std::string::npos ? 0 : a.rfind('\n', i) + 1;
    return a.substr(line, a.find('\n', line) - line) + "\n vs \n" +
           b.substr(line, b.find('\n', line) - line);
  };
  EXPECT_TRUE(functional == lt) << first_difference(functional, lt);
  EXPECT_TRUE(functional == cycle) << first_difference(functional, cycle);
}

TEST(SimLevels, WithOneRayInFlightTheLevelsReadAndWriteTheSameDramBytes) {
  // bvh8-80q: 80-byte records, so a node read covers two L1 lines; each level
  // splits it on its own path.
  for (const char* format : {"", "bvh8-80q"}) {
    SCOPED_TRACE(*format ? format : "preset format");
    SmallWorkload w(format);
    const auto functional = flat_stats(simulate(one_ray_in_flight(w, Fidelity::Functional)).stats.to_json());
    const auto lt = flat_stats(in_child([&] { return simulate(one_ray_in_flight(w, Fidelity::Lt)).stats.to_json(); }));
    const auto cycle = flat_stats(in_child([&] { return simulate(one_ray_in_flight(w, Fidelity::Cycle)).stats.to_json(); }));
    ASSERT_GT(functional.at("dram.bytes"), 0);
    if (*format)  // node reads of two lines each
      ASSERT_GT(functional.at("l1_node.all.accesses"), functional.at("fetches.node"));
    else  // stack spills (the 8-wide tree is too shallow for them)
      ASSERT_GT(functional.at("l1_node.all.writebacks"), 0);
    for (const char* key : {"dram.bytes", "dram.reads", "l1_node.all.accesses", "l1_node.all.hits",
                            "l1_triangle.all.accesses", "l1_triangle.all.hits", "l2.accesses",
                            "l2.hits", "l2.writes", "l1_node.all.writebacks", "l2.writebacks"}) {
      EXPECT_EQ(functional.at(key), lt.at(key)) << key << " lt";
      EXPECT_EQ(functional.at(key), cycle.at(key)) << key << " cycle";
    }
    // One ray in flight: no read ever finds its line on the way.
    EXPECT_EQ(lt.at("l1_node.all.mshr_merges") + lt.at("l2.mshr_merges"), 0);
    EXPECT_EQ(cycle.at("l1_node.all.mshr_merges") + cycle.at("l2.mshr_merges"), 0);
  }
}

TEST(SimLevels, LtDoesNotDependOnItsQuantum) {
  SmallWorkload w;
  std::string first;
  for (uint32_t quantum : {10u, 1000u, 100000u}) {
    const std::string stats = in_child([&] {
      auto r = w.request(Fidelity::Lt);
      r.config.lt_quantum_cycles = quantum;
      return simulate(r).stats.to_json();
    });
    ASSERT_EQ(stats.rfind("ERROR", 0), std::string::npos) << stats;
    if (first.empty()) first = stats;
    else EXPECT_EQ(stats, first) << "quantum " << quantum;
  }
}

TEST(SimLevels, LaterFramesRunWithWarmCachesAndTheSameWork) {
  SmallWorkload w;
  for (Fidelity level : {Fidelity::Functional, Fidelity::Lt, Fidelity::Cycle}) {
    auto once = w.request(level), twice = w.request(level);
    twice.frames = 3;
    const auto run_level = [&](const SimulationRequest& r) {
      if (level == Fidelity::Functional) return flat_stats(simulate(r).stats.to_json());
      return flat_stats(in_child([&] { return simulate(r).stats.to_json(); }));
    };
    const auto a = run_level(once), b = run_level(twice);
    for (const char* key : kOpsAndFetches) EXPECT_EQ(a.at(key), b.at(key)) << key;
    EXPECT_EQ(b.at("time.frames"), 3);
    EXPECT_LT(b.at("dram.bytes"), a.at("dram.bytes")) << fidelity_name(level);
    EXPECT_LT(b.at("l2.accesses"), a.at("l2.accesses")) << fidelity_name(level);
    EXPECT_GT(b.at("l1_node.all.hit_rate"), a.at("l1_node.all.hit_rate")) << fidelity_name(level);
    if (level != Fidelity::Functional) EXPECT_LE(b.at("time.cycles"), a.at("time.cycles"));
  }
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
    r.config.l1_node.mshrs = r.config.l1_triangle.mshrs = 1;
    r.config.l2.mshrs = 16;  // many misses at once for one DRAM queue entry
    r.config.ist_queue_entries = 1;
    r.config.dram.queue_entries = 1;
    r.config.l1_node.size_bytes = r.config.l1_triangle.size_bytes = 256;  // force DRAM traffic
    r.config.l2.size_bytes = 512;
    r.config.l2.associativity = 2;
    return r;
  };
  const auto functional = flat_stats(simulate(tight(Fidelity::Functional)).stats.to_json());
  const auto cycle = flat_stats(in_child([&] { return simulate(tight(Fidelity::Cycle)).stats.to_json(); }));
  for (const char* key : kOpsAndFetches) EXPECT_EQ(functional.at(key), cycle.at(key)) << key;
  EXPECT_GT(cycle.at("l1_node.all.mshr_full_stalls") + cycle.at("l1_triangle.all.mshr_full_stalls"), 0);
  EXPECT_GT(cycle.at("core0.trv0.leaves_blocked"), 0);  // the one IST queue entry held leaves back
  EXPECT_GT(cycle.at("dram.reads"), 0);
  // The full DRAM queue held the L2 back, and that was counted on both sides.
  EXPECT_GT(cycle.at("dram.queue_full_stalls"), 0);
  EXPECT_GT(cycle.at("l2.downstream_refusals"), 0);
  EXPECT_GT(cycle.at("l2.downstream_stall_cycles"), 0);
  // Tighter resources cannot make the same work faster.
  const auto roomy = flat_stats(in_child([&] { return simulate(w.request(Fidelity::Cycle)).stats.to_json(); }));
  EXPECT_GT(cycle.at("time.cycles"), roomy.at("time.cycles"));
}

TEST(SimLevels, FunctionalReportsUnitWorkAndAnEstimate) {
  SmallWorkload w;
  const auto s = flat_stats(simulate(w.request(Fidelity::Functional)).stats.to_json());
  double nodes = 0;
  for (uint32_t u = 0; u < preset("mobile").trv_units; ++u)
    nodes += s.at("core0.trv" + std::to_string(u) + ".passes");
  EXPECT_EQ(nodes, s.at("ops.trv"));
  EXPECT_GE(s.at("time.cycles"), s.at("time.bound_trv_cycles"));
  EXPECT_GE(s.at("time.cycles"), s.at("time.bound_dram_cycles"));
}

TEST(SimLevels, ShuffledFacesGiveIdenticalStatsAtEveryLevelForEveryBuilder) {
  // The memory layout and the builders see geometry only (build_bvh orders the
  // triangles by it; the sampled builders key their rays by geometry or pixel): the
  // file's face order reaches no count, no address and no time.
  const Scene scene = make_procedural_scene("interior");
  Scene shuffled = scene;
  shuffle_triangles(shuffled, 7);
  for (const std::string& builder : builder_names()) {
    BuildParams params;
    params.builder = builder;
    const Bvh a = build_bvh(scene, params), b = build_bvh(shuffled, params);
    for (Fidelity level : {Fidelity::Functional, Fidelity::Lt, Fidelity::Cycle}) {
      auto request = [&](const Scene& s, const Bvh& t) {
        SimulationRequest r;
        r.scene = &s;
        r.bvh = &t;
        r.camera = &s.default_camera();
        r.settings.width = r.settings.height = 32;
        r.config = preset("mobile");
        r.fidelity = level;
        return r;
      };
      const auto run_level = [&](const SimulationRequest& r) {
        if (level == Fidelity::Functional) return simulate(r).stats.to_json();
        return in_child([&] { return simulate(r).stats.to_json(); });  // one SystemC run per process
      };
      const std::string original = run_level(request(scene, a));
      ASSERT_EQ(original.rfind("ERROR", 0), std::string::npos) << original;
      EXPECT_EQ(original, run_level(request(shuffled, b))) << builder << " " << fidelity_name(level);
    }
  }
}

// Wide nodes at the timed levels: a node takes ceil(children / boxes_per_pass)
// passes of the box-test pipeline, and more passes cost cycles.
TEST(SimLevels, WideNodesTakeOnePipelinePassPerBoxesPerPassChildren) {
  const Scene scene = make_procedural_scene("cornell");
  BuildParams params;
  params.builder = "sah";
  apply_node_format(params, node_format("bvh8-80q"));
  const Bvh bvh = build_bvh(scene, params);
  ASSERT_GT(bvh.width(), 4u);
  for (Fidelity level : {Fidelity::Lt, Fidelity::Cycle}) {
    std::map<uint32_t, std::map<std::string, double>> runs;
    for (uint32_t boxes_per_pass : {1u, 8u}) {
      SimulationRequest r;
      r.scene = &scene;
      r.bvh = &bvh;
      r.camera = &scene.cameras.front();
      r.settings.width = r.settings.height = 24;
      r.settings.ao_samples = 2;
      r.config = preset("mobile");
      r.config.node_format = "bvh8-80q";
      r.config.trv_boxes_per_pass = boxes_per_pass;
      r.fidelity = level;
      runs[boxes_per_pass] = flat_stats(in_child([&] { return simulate(r).stats.to_json(); }));
    }
    auto passes = [&](uint32_t bpp) {
      double sum = 0;
      for (uint32_t u = 0; u < preset("mobile").trv_units; ++u)
        sum += runs[bpp].at("core0.trv" + std::to_string(u) + ".passes");
      return sum;
    };
    SCOPED_TRACE(level == Fidelity::Lt ? "lt" : "cycle");
    EXPECT_EQ(passes(8), runs[8].at("ops.trv"));        // every node fits one pass
    EXPECT_EQ(passes(1), runs[1].at("ops.box_tests"));  // one pass per child box
    EXPECT_EQ(runs[1].at("ops.trv"), runs[8].at("ops.trv"));  // timing never changes the work
    EXPECT_GT(runs[1].at("time.cycles"), runs[8].at("time.cycles"));
  }
}

// Several cores with static dispatch: which rays a core traces is fixed by the tiles
// it owns and the rays it spawns, so each core's TRV passes and IST tests are the
// same at every level; the levels also agree on every total count. Dynamic dispatch
// spreads the same total work by timing.
TEST(SimLevels, ManyCoresDoTheSameWorkPerCoreAtEveryLevel) {
  SmallWorkload w;
  const auto request = [&](Fidelity level, const char* dispatch) {
    auto r = w.request(level, 32);
    r.config.cores = 3;
    r.config.trv_units = 2, r.config.ist_units = 1;
    r.config.l2_slices = 2;
    r.config.noc_latency_cycles = 12, r.config.noc_flit_bytes = 16;
    r.config.raygen_tile = "4x4";
    r.config.raygen_dispatch = dispatch;
    return r;
  };
  const auto per_core = [](const std::map<std::string, double>& s) {
    std::string out;
    for (int c = 0; c < 3; ++c) {
      double passes = 0;
      for (int u = 0; u < 2; ++u) passes += s.at("core" + std::to_string(c) + ".trv" + std::to_string(u) + ".passes");
      out += std::to_string(int64_t(passes)) + "/" +
             std::to_string(int64_t(s.at("core" + std::to_string(c) + ".ist0.tests"))) + " ";
    }
    return out;
  };
  const auto functional = flat_stats(simulate(request(Fidelity::Functional, "static")).stats.to_json());
  const auto lt = flat_stats(in_child([&] { return simulate(request(Fidelity::Lt, "static")).stats.to_json(); }));
  const auto cycle = flat_stats(in_child([&] { return simulate(request(Fidelity::Cycle, "static")).stats.to_json(); }));
  const auto dynamic =
      flat_stats(in_child([&] { return simulate(request(Fidelity::Cycle, "dynamic")).stats.to_json(); }));
  EXPECT_EQ(per_core(functional), per_core(lt));
  EXPECT_EQ(per_core(functional), per_core(cycle));
  for (const char* key : {"ops.trv", "ops.ist", "rays.total", "fetches.node", "fetches.triangle"}) {
    EXPECT_EQ(functional.at(key), lt.at(key)) << key;
    EXPECT_EQ(functional.at(key), cycle.at(key)) << key;
    EXPECT_EQ(functional.at(key), dynamic.at(key)) << key;
  }
  // Every core worked, the crossbar carried each L1 miss, and it took time at lt and cycle.
  for (int c = 0; c < 3; ++c) EXPECT_GT(cycle.at("core" + std::to_string(c) + ".trv0.passes"), 0) << c;
  EXPECT_EQ(functional.at("noc.to_slices.messages"),
            functional.at("l2.slice0.accesses") + functional.at("l2.slice1.accesses"));
  EXPECT_GT(cycle.at("noc.wait_cycles_mean"), 0);
  EXPECT_GT(lt.at("noc.to_cores.max_port_utilisation"), 0);
}
