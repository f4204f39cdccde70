// The cache level over the core's CacheTags: hit rates of synthetic address
// traces against hand-computed values, MSHR merging and blocking, one accounting
// (accesses = hits + misses + merges), writes and write-backs, byte attribution
// by (ray type, access kind), and the functional hierarchy behind them.
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/model/sim/memory_system.h>
#include <rtsim/model/sim/port_slots.h>

#include <gtest/gtest.h>

#include <set>

using namespace rtsim;
using namespace rtsim::sim;

namespace {
// 512 bytes, 64-byte lines, 2 ways: 4 sets. Line L maps to set L mod 4.
CacheConfig small_cache() { return CacheConfig{512, 64, 2, 1, 2}; }
LineAccess at(uint64_t line_index, RayType t = RayType::Primary, AccessKind k = AccessKind::Node) {
  return LineAccess{line_index * 64, 64, k, t, false};
}
}  // namespace

TEST(SimCache, WorkingSetThatFitsMissesOnlyOnce) {
  CacheModel cache(small_cache(), "c");
  // 8 distinct lines fill the 4 sets x 2 ways exactly; 10 passes over them:
  // 8 compulsory misses, then all hits -> 72 / 80.
  for (int pass = 0; pass < 10; ++pass)
    for (uint64_t line = 0; line < 8; ++line) cache.access(at(line));
  EXPECT_EQ(cache.counters().accesses, 80u);
  EXPECT_EQ(cache.counters().misses, 8u);
  EXPECT_DOUBLE_EQ(double(cache.counters().hits) / 80.0, 0.9);
}

TEST(SimCache, LruThrashesWhenASetIsOversubscribed) {
  CacheModel cache(small_cache(), "c");
  // Lines 0, 4, 8 all map to set 0 (2 ways): cycling through them under LRU
  // always evicts the line needed next -> hit rate 0.
  for (int pass = 0; pass < 20; ++pass)
    for (uint64_t line : {0, 4, 8}) cache.access(at(line));
  EXPECT_EQ(cache.counters().hits, 0u);
  EXPECT_EQ(cache.counters().misses, 60u);
}

TEST(SimCache, MixedTraceMatchesHandComputation) {
  CacheModel cache(small_cache(), "c");
  // Set 0 sees 0,4,0,8,0,4: miss miss hit miss(evicts 4) hit miss(evicts 8) -> 2 hits.
  // Set 1 sees 1,1,1: miss hit hit -> 2 hits. Total 4 hits of 9.
  for (uint64_t line : {0, 4, 1, 0, 1, 8, 0, 1, 4}) cache.access(at(line));
  EXPECT_EQ(cache.counters().accesses, 9u);
  EXPECT_EQ(cache.counters().hits, 4u);
  EXPECT_EQ(cache.counters().misses, 5u);
}

TEST(SimCache, MshrsMergeAndBlock) {
  using O = CacheModel::Outcome;
  CacheModel cache(small_cache(), "c");  // 2 MSHRs
  EXPECT_EQ(cache.request(at(0)).outcome, O::Miss);
  EXPECT_EQ(cache.request(at(0)).outcome, O::Merged);
  EXPECT_EQ(cache.request(at(1)).outcome, O::Miss);
  EXPECT_EQ(cache.request(at(2)).outcome, O::Blocked);  // both MSHRs busy
  cache.fill(0);
  EXPECT_EQ(cache.request(at(0)).outcome, O::Hit);
  EXPECT_EQ(cache.request(at(2)).outcome, O::Miss);
  const auto& c = cache.counters();
  EXPECT_EQ(c.mshr_merges, 1u);
  EXPECT_EQ(c.mshr_full_stalls, 1u);
  EXPECT_EQ(c.accesses, 5u);  // a blocked request is not an access yet
  EXPECT_EQ(c.accesses, c.hits + c.misses + c.mshr_merges);
  EXPECT_EQ(c.hits, 1u);
}

TEST(SimCache, LtReadsOfALineOnItsWayMergeAndWaitForIt) {
  // The same accounting as the cycle level: a read before the fill lands is a merge.
  using O = CacheModel::Outcome;
  CacheModel cache(small_cache(), "c");
  const auto miss = cache.access(at(3), 1000);
  EXPECT_EQ(miss.outcome, O::Miss);
  EXPECT_TRUE(miss.fetch);
  cache.set_arrival(3 * 64, 5000);
  const auto early = cache.access(at(3), 2000);
  EXPECT_EQ(early.outcome, O::Merged);
  EXPECT_EQ(early.ready_ps, 5000u);
  EXPECT_EQ(cache.access(at(3), 5000).outcome, O::Hit);
  const auto& c = cache.counters();
  EXPECT_EQ(c.accesses, 3u);
  EXPECT_EQ(c.hits, 1u);
  EXPECT_EQ(c.misses, 1u);
  EXPECT_EQ(c.mshr_merges, 1u);
  // Functional: no time, so no merges.
  CacheModel untimed(small_cache(), "f");
  untimed.access(at(3));
  EXPECT_EQ(untimed.access(at(3)).outcome, O::Hit);
}

TEST(SimCache, WritesAllocateWithoutAFillAndDirtyLinesAreWrittenBack) {
  CacheModel cache(small_cache(), "c");  // set 0 holds lines 0, 4, 8, ... (2 ways)
  LineAccess w = at(0, RayType::Primary, AccessKind::Stack);
  w.write = true;
  const auto r = cache.access(w);
  EXPECT_EQ(r.outcome, CacheModel::Outcome::Miss);
  EXPECT_FALSE(r.fetch);  // nothing read from below
  EXPECT_EQ(cache.filled().total(), 0u);
  cache.access(at(4));
  const auto evict = cache.access(at(8));  // line 0 is the LRU, and dirty
  EXPECT_TRUE(evict.writeback.dirty);
  EXPECT_EQ(evict.writeback.line, 0u);
  EXPECT_EQ(cache.counters().writebacks, 1u);
  EXPECT_EQ(cache.counters().writes, 1u);
  // Cycle level: a write miss needs no MSHR and completes at once.
  CacheModel timed(small_cache(), "t");
  const auto wr = timed.request(w);
  EXPECT_EQ(wr.outcome, CacheModel::Outcome::Miss);
  EXPECT_FALSE(wr.fetch);
  EXPECT_EQ(timed.mshrs_in_use(), 0u);
}

TEST(SimCache, PortsServeSoManyAccessesPerCycle) {
  CacheConfig config = small_cache();
  config.ports = 2;
  CacheModel cache(config, "c", 1000);
  EXPECT_EQ(cache.reserve_port(0), 0u);
  EXPECT_EQ(cache.reserve_port(0), 500u);
  EXPECT_EQ(cache.reserve_port(0), 1000u);
  EXPECT_EQ(cache.reserve_port(5000), 5000u);
  EXPECT_EQ(cache.counters().port_wait_ps, 1500u);
  // A request that comes late (it waited upstream) takes a free slot at its own
  // time, not the slot after the latest taken.
  EXPECT_EQ(cache.reserve_port(2000), 2000u);
  EXPECT_EQ(cache.reserve_port(2000), 2500u);
  EXPECT_EQ(cache.reserve_port(5000), 5500u);
  // Far later (the port's slot record wraps around many times): slots taken long
  // ago do not block the ones that now fall on the same place in the record
  // (1'016'384'000 is 32768 slots, the record's length here, after 1'000'000'000).
  for (uint64_t t : {uint64_t(1'000'000'000), uint64_t(1'016'384'000), uint64_t(1'000'000'000'000)}) {
    EXPECT_EQ(cache.reserve_port(t), t);
    EXPECT_EQ(cache.reserve_port(t), t + 500);
    EXPECT_EQ(cache.reserve_port(t + 500), t + 1000);
    EXPECT_EQ(cache.reserve_port(t - 500), t - 500) << "a late request still finds its free slot";
  }
}

TEST(SimCache, PortSlotsAgreeWithASetOfTakenSlots) {
  // A port's slot record against the plainest model of it, a set of taken slots:
  // a walk of reservations, mostly forward in time by 0 to 3 slots, sometimes
  // jumping ahead by up to two record words or further than the record holds,
  // sometimes coming late (within the horizon, where every slot is remembered).
  constexpr uint64_t kInterval = 500, kHorizonSlots = 400;
  PortSlots port(kInterval, kHorizonSlots * kInterval);
  std::set<uint64_t> taken;
  uint64_t newest = 0, state = 12345;
  const auto next = [&state](uint64_t n) {  // a small LCG: the same walk on every machine
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return (state >> 33) % n;
  };
  for (int i = 0; i < 200000; ++i) {
    const uint64_t kind = next(100);
    uint64_t slot = newest + next(4);
    if (kind < 10) slot = newest + next(130);
    else if (kind < 11) slot = newest + 100000 + next(1000);
    else if (kind < 30 && newest >= kHorizonSlots) slot = newest - next(kHorizonSlots);
    uint64_t expected = slot;
    while (taken.count(expected)) ++expected;
    ASSERT_EQ(port.first_free(slot), expected) << "step " << i << ", slot " << slot;
    port.take(expected);
    taken.insert(expected);
    newest = std::max(newest, expected);
  }
}

TEST(SimHierarchy, StreamingTwiceOverACacheSizedRegionHitsTheL2TheSecondTime) {
  HardwareConfig config = preset("mobile");
  config.trv_units = config.ist_units = 1;
  config.l1_node = {1024, 64, 2, 1, 4};      // 16 lines
  config.l1_triangle = {1024, 64, 2, 1, 4};
  config.l2 = {4096, 64, 4, 1, 4};           // 64 lines
  FunctionalMemory memory(config);
  FunctionalMemorySink sink(memory);
  // 32 nodes of 64 B = 2 KB: twice the L1, half the L2. Two passes, in order.
  for (int pass = 0; pass < 2; ++pass)
    for (uint64_t i = 0; i < 32; ++i) {
      sink.on_access({0x10000 + i * 64, 64, AccessKind::Node, false}, RayType::Primary);
      sink.on_step_end();
    }
  EXPECT_EQ(memory.l1_node[0]->counters().accesses, 64u);
  EXPECT_EQ(memory.l1_node[0]->counters().hits, 0u);  // LRU streaming twice its size
  EXPECT_EQ(memory.l2.front()->counters().accesses, 64u);
  EXPECT_EQ(memory.l2.front()->counters().hits, 32u);
  EXPECT_EQ(memory.dram.counters().bytes, 32u * 64u);
  // A 36-byte triangle straddling two lines is two L1 accesses; two triangles in
  // one line of one step are one.
  sink.on_access({0x20000 + 40, 36, AccessKind::Triangle, false}, RayType::Ao);
  sink.on_step_end();
  EXPECT_EQ(memory.l1_triangle[0]->counters().accesses, 2u);
  EXPECT_EQ(memory.l1_triangle[0]->requested().total(), 36u);
  sink.on_access({0x30000, 32, AccessKind::Triangle, false}, RayType::Ao);
  sink.on_access({0x30000 + 32, 32, AccessKind::Triangle, false}, RayType::Ao);
  sink.on_step_end();
  EXPECT_EQ(memory.l1_triangle[0]->counters().accesses, 3u);
  EXPECT_EQ(memory.l2.front()->filled().bytes[size_t(RayType::Ao)][size_t(AccessKind::Triangle)], 3u * 64u);
}

TEST(SimHierarchy, DirtyLinesTravelDownToDramAsWrites) {
  HardwareConfig config = preset("mobile");
  config.trv_units = config.ist_units = 1;
  config.l1_node = {512, 64, 1, 1, 4};  // 8 lines, direct mapped
  config.l2 = {1024, 64, 1, 1, 4};      // 16 lines, direct mapped
  FunctionalMemory memory(config);
  // Write line A, then read lines that evict it from L1 (into L2, dirty) and from L2.
  const LineAccess a{0, 8, AccessKind::Stack, RayType::Primary, true};
  memory.access(Requester::Trv, 0, a, 0);
  EXPECT_EQ(memory.dram.counters().bytes, 0u);
  memory.access(Requester::Trv, 0, {512, 64, AccessKind::Node, RayType::Primary, false}, 0);
  EXPECT_EQ(memory.l1_node[0]->counters().writebacks, 1u);
  EXPECT_EQ(memory.l2.front()->counters().writes, 1u);
  memory.access(Requester::Trv, 0, {1024, 64, AccessKind::Node, RayType::Primary, false}, 0);
  EXPECT_EQ(memory.l2.front()->counters().writebacks, 1u);
}

TEST(SimCache, BytesAreAttributedByRayTypeAndKind) {
  CacheModel cache(small_cache(), "c");
  cache.access(LineAccess{0, 36, AccessKind::Triangle, RayType::Ao});
  cache.access(LineAccess{0, 36, AccessKind::Triangle, RayType::Ao});
  cache.access(LineAccess{64, 64, AccessKind::Node, RayType::Primary});
  const auto& req = cache.requested().bytes;
  const auto& fill = cache.filled().bytes;
  EXPECT_EQ(req[size_t(RayType::Ao)][size_t(AccessKind::Triangle)], 72u);
  EXPECT_EQ(fill[size_t(RayType::Ao)][size_t(AccessKind::Triangle)], 64u);  // one line fill
  EXPECT_EQ(req[size_t(RayType::Primary)][size_t(AccessKind::Node)], 64u);
  EXPECT_EQ(cache.filled().total(), 128u);
}

// A dirty line that leaves is written back for the ray type that wrote it, not for
// the one whose miss pushed it out (a primary ray's fill evicting an AO ray's spill
// is still AO traffic): at a hit, at a write miss, and through an MSHR's fill.
TEST(SimCache, AWriteBackIsChargedToTheRayTypeThatWroteTheLine) {
  const auto write = [](uint64_t line, RayType t) {
    LineAccess a = at(line, t, AccessKind::Stack);
    a.write = true;
    return a;
  };
  CacheModel cache(small_cache(), "c");
  cache.access(write(0, RayType::Ao));         // set 0, way 1: written by an AO ray
  cache.access(at(4, RayType::Shadow));        // set 0, way 2 (clean)
  cache.access(at(4, RayType::Shadow));        // 4 most recent: 0 is the victim
  const CacheModel::Result r = cache.access(at(8, RayType::Primary));
  ASSERT_TRUE(r.writeback.dirty);
  EXPECT_EQ(r.writeback.line, 0u);
  EXPECT_EQ(r.writeback.writer, RayType::Ao);

  // The last write decides: a reflection ray overwrites a line a primary ray dirtied.
  CacheModel later(small_cache(), "c");
  later.access(write(1, RayType::Primary));
  later.access(write(1, RayType::Reflection));
  later.access(at(5));
  const CacheModel::Result r2 = later.access(at(9));
  ASSERT_TRUE(r2.writeback.dirty);
  EXPECT_EQ(r2.writeback.writer, RayType::Reflection);

  // A write that meets a line whose fill is under way makes the filled line its
  // writer's. Set 2 holds lines 2, 6, 10 (2 ways).
  CacheModel cycle(small_cache(), "c");
  EXPECT_EQ(cycle.request(at(2, RayType::Primary)).outcome, CacheModel::Outcome::Miss);
  EXPECT_EQ(cycle.request(write(2, RayType::Shadow)).outcome, CacheModel::Outcome::Merged);
  EXPECT_FALSE(cycle.fill(2 * 64).valid);
  cycle.request(at(6));
  EXPECT_FALSE(cycle.fill(6 * 64).valid);
  cycle.request(at(6));  // a hit: line 2 is the set's oldest
  EXPECT_EQ(cycle.request(at(10)).outcome, CacheModel::Outcome::Miss);
  const Eviction e = cycle.fill(10 * 64);
  ASSERT_TRUE(e.dirty);
  EXPECT_EQ(e.line, 2u * 64);
  EXPECT_EQ(e.writer, RayType::Shadow);
}
