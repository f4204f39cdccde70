// The ray-reordering unit (ray_reorder.h): it sorts each batch by its key, issues
// every ray exactly once, leaves ops and fetches alone at every level, costs its
// sort latency at the timed levels, and is absent from the stats when not built.
#include "sim_test_support.h"

#include <rtsim/model/core/traversal.h>
#include <rtsim/model/sim/ray_dispatch.h>
#include <rtsim/model/sim/ray_reorder.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/geometry.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>

using namespace rtsim;
using namespace rtsim::sim;
using namespace rtsim::sim::test;

namespace {

SimulationRequest with_unit(const SmallWorkload& w, Fidelity level, uint32_t batch, const char* key) {
  auto r = w.request(level);
  r.config.reorder_batch_rays = batch;
  r.config.reorder_key = key;
  return r;
}

std::map<std::string, double> run(const SimulationRequest& r) {
  if (r.fidelity == Fidelity::Functional) return flat_stats(simulate(r).stats.to_json());
  return flat_stats(in_child([&] { return simulate(r).stats.to_json(); }));
}

// Work a ray does whatever order it is issued in.
const char* kPerRayWork[] = {"ops.trv",          "ops.ist",           "ops.box_tests",
                             "fetches.node",     "fetches.triangle",  "fetches.prim_ref",
                             "rays.total",       "per_type.ao.rays",  "per_type.primary.trv_ops",
                             "per_type.ao.ist_ops", "stack.overflows"};

}  // namespace

TEST(RayReorder, SortCyclesAreTheBitonicNetworksDepth) {
  HardwareConfig c = preset("mobile");
  c.reorder_stage_cycles = 1;
  EXPECT_EQ(reorder_sort_cycles(c, 0), 0u);
  EXPECT_EQ(reorder_sort_cycles(c, 1), 0u);
  EXPECT_EQ(reorder_sort_cycles(c, 2), 1u);
  EXPECT_EQ(reorder_sort_cycles(c, 256), 36u);  // k = 8: 8 x 9 / 2
  EXPECT_EQ(reorder_sort_cycles(c, 257), 45u);  // k = 9
  c.reorder_stage_cycles = 3;
  EXPECT_EQ(reorder_sort_cycles(c, 1024), 165u);  // k = 10: 55 stages
}

TEST(RayReorder, EachBatchLeavesSortedByItsKeyAndEveryRayOnce) {
  // Foliage: cornell's root has a child as large as the room, which every ray
  // enters first, so its first_node keys would all be equal.
  SmallWorkload w;
  w.scene = make_procedural_scene("foliage");
  BuildParams params;
  params.builder = "sah";
  w.bvh = build_bvh(w.scene, params);
  const HardwareConfig config = preset("mobile");
  const MemoryImage image(w.scene, w.bvh, memory_layout_for(config));
  const TraversalContext context(w.scene, w.bvh, image, traversal_config_for(config));
  const Aabb box = w.bvh.root().bounds;
  // 13 x 11 rays from points around the scene (outside its box, in an order
  // unrelated to their Morton codes) towards points inside it: their directions
  // cover every octant and they enter the tree through different children.
  const uint32_t width = 13, height = 11;
  std::vector<Ray> rays(width * height);
  const vec3 centre = (box.lo + box.hi) * 0.5f, extent = box.hi - box.lo;
  for (uint32_t i = 0; i < rays.size(); ++i) {
    const float u = float((i * 37) % 101) / 100, v = float((i * 53) % 89) / 88, s = float((i * 71) % 97) / 96;
    const vec3 from = centre + extent * 1.5f * glm::normalize(vec3{u - 0.5f, v - 0.5f, s - 0.45f});
    const vec3 to = box.lo + extent * vec3{v, s, u};
    rays[i].pixel = i;
    rays[i].origin = from;
    rays[i].direction = glm::normalize(to - from);
  }
  for (const char* key : {"none", "origin", "octant_origin", "first_node"}) {
    SCOPED_TRACE(key);
    IssuePolicy policy;
    policy.order = IssuePolicy::Order::Scanline;
    policy.reorder.batch_rays = 16;
    policy.reorder.key = parse_reorder_key(key);
    RayDispatcher d(policy, rays, width, height, false, &context);
    const RayReorderKeys keys(policy.reorder.key, context);
    std::vector<uint32_t> issued;
    uint32_t r;
    while (d.next(0, UINT64_MAX, &r)) issued.push_back(r);
    ASSERT_EQ(issued.size(), rays.size());
    EXPECT_EQ(std::set<uint32_t>(issued.begin(), issued.end()).size(), rays.size());
    bool reordered = false;
    for (size_t start = 0; start < issued.size(); start += 16) {
      const size_t end = std::min(issued.size(), start + 16);
      for (size_t i = start + 1; i < end; ++i) {
        const uint64_t before = keys(rays[issued[i - 1]]), after = keys(rays[issued[i]]);
        ASSERT_LE(before, after) << "batch at " << start << ", position " << i;
        // Equal keys keep their arrival order (stable).
        if (before == after) EXPECT_LT(issued[i - 1], issued[i]);
        reordered |= issued[i - 1] > issued[i];
      }
      // A batch holds the next 16 rays of ray generation, whatever their order.
      std::vector<uint32_t> batch(issued.begin() + long(start), issued.begin() + long(end));
      std::sort(batch.begin(), batch.end());
      EXPECT_EQ(batch.front(), start);
      EXPECT_EQ(batch.back(), end - 1);
    }
    EXPECT_EQ(reordered, std::string(key) != "none") << "the key did not reorder anything";
    if (std::string(key) == "first_node") {
      std::set<uint64_t> distinct;
      for (const Ray& ray : rays) distinct.insert(keys(ray));
      EXPECT_GE(distinct.size(), 2u) << "every ray enters the same node: the test shows nothing";
    }
    const ReorderFigures f = d.reorder_unit()->figures();
    EXPECT_EQ(f.total.rays, rays.size());
    EXPECT_EQ(f.total.batches, (rays.size() + 15) / 16);
    EXPECT_EQ(f.total.full_batches, rays.size() / 16);
    EXPECT_EQ(f.key_box_tests > 0, std::string(key) == "first_node");
  }
}

TEST(RayReorder, KeyNoneWithSecondariesAfterChangesNoFunctionalStat) {
  // Secondaries after every primary: the unit's batches then issue exactly the order
  // ray generation has, so only the unit's own stats and energy may differ.
  SmallWorkload w;
  auto plain = w.request(Fidelity::Functional);
  plain.config.raygen_secondary = "after";
  auto unit = plain;
  unit.config.reorder_batch_rays = 64;
  unit.config.reorder_key = "none";
  const auto off = run(plain), on = run(unit);
  size_t compared = 0;
  for (const auto& [key, value] : off) {
    if (key.rfind("energy.", 0) == 0 || key.rfind("config.", 0) == 0) continue;
    ASSERT_TRUE(on.count(key)) << key;
    EXPECT_EQ(value, on.at(key)) << key;
    ++compared;
  }
  EXPECT_GT(compared, 50u);
  EXPECT_EQ(on.at("reorder.rays"), off.at("rays.total"));
}

TEST(RayReorder, EveryLevelIssuesEveryRayOnceAndDoesTheSameWork) {
  SmallWorkload w;
  const auto off = run(w.request(Fidelity::Functional));
  for (const char* key : {"origin", "first_node"}) {
    SCOPED_TRACE(key);
    const auto functional = run(with_unit(w, Fidelity::Functional, 32, key));
    const auto lt = run(with_unit(w, Fidelity::Lt, 32, key));
    const auto cycle = run(with_unit(w, Fidelity::Cycle, 32, key));
    ASSERT_GT(off.at("per_type.ao.rays"), 0);
    for (const char* stat : kPerRayWork) {
      EXPECT_EQ(functional.at(stat), off.at(stat)) << stat;
      EXPECT_EQ(lt.at(stat), off.at(stat)) << stat << " lt";
      EXPECT_EQ(cycle.at(stat), off.at(stat)) << stat << " cycle";
    }
    for (const auto* level : {&functional, &lt, &cycle}) {
      EXPECT_EQ(level->at("reorder.rays"), off.at("rays.total"));
      EXPECT_GT(level->at("energy.reorder.pj"), 0);
      // The unit's energy is in the total, which is still the sum of its components.
      double sum = 0;
      for (const auto& [stat, value] : *level)
        if (stat.rfind("energy.", 0) == 0 && stat.size() > 3 && stat.compare(stat.size() - 3, 3, ".pj") == 0 &&
            stat != "energy.dram_background.pj")
          sum += value;
      EXPECT_NEAR(sum, level->at("energy.total_pj"), 1e-9 * sum);
    }
    // Functional: a batch is short only when ray generation has no more rays
    // queued (at the end of the frame, while the last rays' secondaries come).
    EXPECT_LE(functional.at("reorder.full_batches") * 32, off.at("rays.total"));
    EXPECT_GE(functional.at("reorder.batches") * 32, off.at("rays.total"));
    EXPECT_GT(functional.at("reorder.full_batches"), 0.9 * functional.at("reorder.batches"));
    EXPECT_FALSE(functional.count("reorder.wait_cycles_per_ray"));
  }
}

TEST(RayReorder, ATimedRayWaitsAtLeastTheSortLatency) {
  SmallWorkload w;
  for (Fidelity level : {Fidelity::Lt, Fidelity::Cycle}) {
    auto r = with_unit(w, level, 256, "origin");
    r.config.reorder_stage_cycles = 4;
    const double latency = reorder_sort_cycles(r.config, 256);  // 144 cycles
    const auto on = run(r);
    r.config.reorder_batch_rays = 0;
    const auto off = run(r);
    EXPECT_GE(on.at("reorder.wait_cycles_per_ray"), latency);
    EXPECT_GT(on.at("time.cycles"), off.at("time.cycles") + latency) << "the first batch alone waits that long";
  }
}

TEST(RayReorder, IsDeterministic) {
  SmallWorkload w;
  const auto r = with_unit(w, Fidelity::Cycle, 64, "octant_origin");
  const auto a = in_child([&] { return simulate(r).stats.to_json(); });
  const auto b = in_child([&] { return simulate(r).stats.to_json(); });
  ASSERT_EQ(a.rfind("ERROR", 0), std::string::npos) << a;
  EXPECT_EQ(a, b);
}

TEST(RayReorder, NoUnitNoStats) {
  SmallWorkload w;
  const auto off = run(w.request(Fidelity::Functional));
  for (const auto& [key, value] : off) {
    EXPECT_NE(key.rfind("reorder.", 0), 0u) << key;
    EXPECT_NE(key.rfind("energy.reorder", 0), 0u) << key;
  }
}

TEST(RayReorder, ABadKeyIsRefusedByName) {
  std::string message;
  try {
    parse_hardware_config("[reorder]\nbatch_rays = 64\nkey = \"zigzag\"\n", "unit.toml");
  } catch (const InputError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("reorder.key"), std::string::npos) << message;
  EXPECT_NE(message.find("zigzag"), std::string::npos) << message;
  try {
    parse_hardware_config("[reorder]\nbatch_rays = 5000\n", "unit.toml");
    message.clear();
  } catch (const InputError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("reorder.batch_rays"), std::string::npos) << message;
}
