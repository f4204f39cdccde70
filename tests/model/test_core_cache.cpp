// Cache tags and the functional hierarchy against hand-computed traces.
#include <rtsim/model/core/cache_tags.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

using namespace rtsim;

TEST(CoreCacheTags, TwoWayLruHandComputed) {
  // 2 sets x 2 ways x 64 B. Lines A, C, E map to set 0 (line index even), B to set 1.
  CacheTags tags({256, 64, 2});
  ASSERT_EQ(tags.sets(), 2u);
  const uint64_t A = 0x000, B = 0x040, C = 0x080, E = 0x100;
  const std::pair<uint64_t, bool> trace[] = {
      {A, false}, {A + 8, true},  // same line
      {B, false}, {C, false},     // set 0 now {A, C}
      {A, true},                  // A most recent: C is LRU
      {E, false},                 // evicts C
      {C, false},                 // evicts A (LRU after E)
      {E, true},  {A, false},     // evicts C
      {B, true},
  };
  int hits = 0;
  for (const auto& [address, expected] : trace) {
    const bool hit = tags.access(address);
    EXPECT_EQ(hit, expected) << std::hex << address;
    hits += hit;
  }
  EXPECT_EQ(hits, 4);
}

TEST(CoreCacheTags, InsertReportsTheEvictedLine) {
  CacheTags tags({128, 64, 1});  // direct mapped, 2 sets
  uint64_t evicted = 0;
  EXPECT_FALSE(tags.insert(0x1000, &evicted));
  EXPECT_FALSE(tags.insert(0x1010, &evicted));  // same line: refresh
  EXPECT_TRUE(tags.insert(0x1080, &evicted));
  EXPECT_EQ(evicted, 0x1000u);
  EXPECT_TRUE(tags.contains(0x10bf));
  EXPECT_FALSE(tags.contains(0x1000));
  EXPECT_FALSE(tags.lookup(0x1000));
}

TEST(CoreCacheTags, BadGeometryIsRefusedNamingTheField) {
  try {
    CacheTags tags({1000, 48, 2}, "cache.l1_node");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cache.l1_node.line_bytes"), std::string::npos);
  }
  EXPECT_THROW(CacheTags({64 * 3 * 2, 64, 2}), InputError);  // 3 sets
  EXPECT_THROW(CacheTags({64, 64, 0}), InputError);
}

TEST(CoreCacheHierarchy, StreamingTwiceOverACacheSizedRegionHitsTheSecondTime) {
  CacheHierarchyConfig config;
  config.l1_node = {1024, 64, 2};      // 16 lines
  config.l1_triangle = {1024, 64, 2};
  config.l2 = {4096, 64, 4};           // 64 lines
  FunctionalCacheHierarchy h(config);
  // 32 nodes of 64 B = 2 KB: twice the L1, half the L2. Two passes, in order.
  for (int pass = 0; pass < 2; ++pass)
    for (uint64_t i = 0; i < 32; ++i) h.on_fetch({0x10000 + i * 64, 64, FetchKind::Node, RayType::Primary});
  // L1 (LRU, streaming a region twice its size): every access misses.
  EXPECT_EQ(h.l1_node().accesses, 64u);
  EXPECT_EQ(h.l1_node().hits, 0u);
  // L2 holds all 32 lines: the second pass hits.
  EXPECT_EQ(h.l2().accesses, 64u);
  EXPECT_EQ(h.l2().hits, 32u);
  EXPECT_EQ(h.dram_bytes(), 32u * 64u);
  // A 36-byte triangle straddling two lines is two L1 accesses.
  h.on_fetch({0x20000 + 40, 36, FetchKind::Triangle, RayType::Ao});
  EXPECT_EQ(h.l1_triangle().accesses, 2u);
  EXPECT_EQ(h.l1_triangle().bytes_requested, 36u);
  EXPECT_EQ(h.dram_bytes_by_ray_type()[ray_type_index(RayType::Ao)], 128u);
  EXPECT_DOUBLE_EQ(h.l2().hit_rate(), 32.0 / 66.0);
}
