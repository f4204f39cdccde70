// The timing model's cache level over the core's CacheTags: hit rates of
// synthetic address traces against hand-computed values, MSHR merging and
// blocking, and byte attribution by (ray type, data kind).
#include <rtsim/model/sim/cache_model.h>

#include <gtest/gtest.h>

using namespace rtsim;
using namespace rtsim::sim;

namespace {
// 512 bytes, 64-byte lines, 2 ways: 4 sets. Line L maps to set L mod 4.
CacheConfig small_cache() { return CacheConfig{512, 64, 2, 1, 2}; }
LineAccess at(uint64_t line_index, RayType t = RayType::Primary, DataKind k = DataKind::Node) {
  return LineAccess{line_index * 64, 64, k, t};
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
  CacheModel cache(small_cache(), "c");  // 2 MSHRs
  EXPECT_EQ(cache.request(at(0)), CacheModel::Outcome::Miss);
  EXPECT_EQ(cache.request(at(0)), CacheModel::Outcome::Merged);
  EXPECT_EQ(cache.request(at(1)), CacheModel::Outcome::Miss);
  EXPECT_EQ(cache.request(at(2)), CacheModel::Outcome::Blocked);  // both MSHRs busy
  cache.fill(0);
  EXPECT_EQ(cache.request(at(0)), CacheModel::Outcome::Hit);
  EXPECT_EQ(cache.request(at(2)), CacheModel::Outcome::Miss);
  EXPECT_EQ(cache.counters().mshr_merges, 1u);
  EXPECT_EQ(cache.counters().mshr_full_stalls, 1u);
  EXPECT_EQ(cache.counters().accesses, 5u);  // a blocked request is not an access yet
}

TEST(SimCache, BytesAreAttributedByRayTypeAndKind) {
  CacheModel cache(small_cache(), "c");
  cache.access(LineAccess{0, 36, DataKind::Triangle, RayType::Ao});
  cache.access(LineAccess{0, 36, DataKind::Triangle, RayType::Ao});
  cache.access(LineAccess{64, 64, DataKind::Node, RayType::Primary});
  const auto& req = cache.requested().bytes;
  const auto& fill = cache.filled().bytes;
  EXPECT_EQ(req[size_t(RayType::Ao)][size_t(DataKind::Triangle)], 72u);
  EXPECT_EQ(fill[size_t(RayType::Ao)][size_t(DataKind::Triangle)], 64u);  // one line fill
  EXPECT_EQ(req[size_t(RayType::Primary)][size_t(DataKind::Node)], 64u);
  EXPECT_EQ(cache.filled().total(), 128u);
}
