// Cache tags against hand-computed traces.
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

TEST(CoreCacheTags, InsertReportsTheEvictedLineAndWhetherItWasDirty) {
  CacheTags tags({128, 64, 1});  // direct mapped, 2 sets
  EXPECT_FALSE(tags.insert(0x1000).valid);
  EXPECT_FALSE(tags.insert(0x1010).valid);  // same line: refresh
  Eviction e = tags.insert(0x1080);
  EXPECT_TRUE(e.valid);
  EXPECT_FALSE(e.dirty);
  EXPECT_EQ(e.line, 0x1000u);
  EXPECT_TRUE(tags.contains(0x10bf));
  EXPECT_FALSE(tags.contains(0x1000));
  EXPECT_FALSE(tags.lookup(0x1000));
  // A written line leaves dirty; a clean refill of it is clean again.
  EXPECT_TRUE(tags.lookup(0x1080, true));
  e = tags.insert(0x1100);
  EXPECT_TRUE(e.dirty);
  EXPECT_EQ(e.line, 0x1080u);
  EXPECT_FALSE(tags.insert(0x1080).dirty);  // evicts clean 0x1100
  e = tags.insert(0x1000, true);            // set 0 again: 0x1080 clean goes
  EXPECT_FALSE(e.dirty);
  EXPECT_TRUE(tags.insert(0x1080).dirty);   // the dirty install of 0x1000 leaves dirty
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

