// The issue policy shared by every level: primary orders, secondary rays behind
// or after, and the slot order that spreads rays over the units.
#include <rtsim/model/sim/ray_dispatch.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

using namespace rtsim;
using namespace rtsim::sim;

namespace {
IssuePolicy policy(IssuePolicy::Order order, uint32_t tw = 4, uint32_t th = 2, bool behind = true) {
  IssuePolicy p;
  p.order = order;
  p.tile_width = tw, p.tile_height = th;
  p.secondary_behind = behind;
  return p;
}
std::vector<Ray> primaries(uint32_t w, uint32_t h) {
  std::vector<Ray> rays(size_t(w) * h);
  for (uint32_t i = 0; i < rays.size(); ++i) rays[i].pixel = i;
  return rays;
}
std::vector<uint32_t> drain(RayDispatcher& d) {
  std::vector<uint32_t> out;
  uint32_t r;
  while (d.next(0, UINT64_MAX, &r)) out.push_back(r);
  return out;
}
}  // namespace

TEST(SimDispatch, EveryOrderIsAPermutationOfThePixels) {
  for (auto order : {IssuePolicy::Order::Scanline, IssuePolicy::Order::Tiles, IssuePolicy::Order::Morton})
    for (auto [w, h] : {std::pair{16u, 16u}, std::pair{13u, 7u}, std::pair{1u, 5u}}) {
      const auto p = pixel_issue_order(w, h, policy(order, 5, 3));
      ASSERT_EQ(p.size(), size_t(w) * h);
      EXPECT_EQ(std::set<uint32_t>(p.begin(), p.end()).size(), p.size());
      EXPECT_LT(*std::max_element(p.begin(), p.end()), w * h);
    }
}

TEST(SimDispatch, TilesAndMortonKeepNeighboursTogether) {
  const auto tiles = pixel_issue_order(8, 4, policy(IssuePolicy::Order::Tiles, 4, 2));
  // The first tile: rows 0 and 1, columns 0..3.
  EXPECT_EQ(std::vector<uint32_t>(tiles.begin(), tiles.begin() + 8),
            (std::vector<uint32_t>{0, 1, 2, 3, 8, 9, 10, 11}));
  EXPECT_EQ(tiles[8], 4u);  // then the tile to its right
  const auto morton = pixel_issue_order(4, 4, policy(IssuePolicy::Order::Morton));
  EXPECT_EQ(std::vector<uint32_t>(morton.begin(), morton.begin() + 8),
            (std::vector<uint32_t>{0, 1, 4, 5, 2, 3, 6, 7}));
  const auto scan = pixel_issue_order(4, 2, policy(IssuePolicy::Order::Scanline));
  EXPECT_EQ(scan, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 6, 7}));
}

TEST(SimDispatch, SpawnedRaysGoBehindTheirParentOrAfterEveryPrimary) {
  for (bool behind : {true, false}) {
    RayDispatcher d(policy(IssuePolicy::Order::Scanline, 4, 2, behind), primaries(4, 1), 4, 1, true);
    uint32_t r;
    ASSERT_TRUE(d.next(0, 0, &r));
    EXPECT_EQ(r, 0u);
    std::vector<Ray> ao(2);
    ao[0].type = ao[1].type = RayType::Ao;
    d.add_spawned(0, ao, 100);  // rays 4 and 5, ready at 100
    ASSERT_TRUE(d.next(0, 50, &r));
    EXPECT_EQ(r, 1u) << "not ready yet: a primary goes first";
    ASSERT_TRUE(d.next(0, 100, &r));
    EXPECT_EQ(r, behind ? 4u : 2u);
    const auto rest = drain(d);
    EXPECT_EQ(rest, behind ? (std::vector<uint32_t>{5, 2, 3}) : (std::vector<uint32_t>{3, 4, 5}));
    EXPECT_TRUE(d.empty());
    d.restart();
    EXPECT_EQ(d.rays().size(), 4u);
    EXPECT_EQ(drain(d).size(), 4u);
  }
}

TEST(SimDispatch, AReplayedSetIsOrderedWithItsParentLinks) {
  // Rays 0..2 primary (pixels 2, 0, 1), rays 3, 4 children of 0, ray 5 child of 1.
  std::vector<Ray> rays(6);
  rays[0].pixel = 2, rays[1].pixel = 0, rays[2].pixel = 1;
  rays[3].parent = rays[4].parent = 0, rays[5].parent = 1;
  rays[3].type = rays[4].type = rays[5].type = RayType::Ao;
  RayDispatcher behind(policy(IssuePolicy::Order::Scanline, 4, 2, true), rays, 3, 1, false);
  EXPECT_EQ(drain(behind), (std::vector<uint32_t>{1, 5, 2, 0, 3, 4}));
  RayDispatcher after(policy(IssuePolicy::Order::Scanline, 4, 2, false), rays, 3, 1, false);
  EXPECT_EQ(drain(after), (std::vector<uint32_t>{1, 2, 0, 3, 4, 5}));
}

TEST(SimDispatch, SlotsFillUnitByUnitInTurn) {
  EXPECT_EQ(free_slot_order(3, 2), (std::vector<uint32_t>{0, 2, 4, 1, 3, 5}));
}

TEST(SimDispatch, TheTileIsParsedStrictly) {
  EXPECT_EQ(parse_tile("16x8"), (std::pair<uint32_t, uint32_t>{16, 8}));
  for (const char* bad : {"", "8", "0x8", "8x", "8x8x", "-8x8", "8 x 8", "99999x1"})
    EXPECT_THROW(parse_tile(bad), std::exception) << bad;
}

// Several cores: the issue order cut into screen tiles, tile i to core i mod cores
// (static) or to whichever core runs out first (dynamic); spawned rays stay on
// the core that spawned them.
TEST(SimDispatch, TilesGoToCoresRoundRobinOrOnDemandAndSecondariesStayHome) {
  IssuePolicy p = policy(IssuePolicy::Order::Tiles, 2, 2);
  p.cores = 2;
  {
    RayDispatcher d(p, primaries(4, 4), 4, 4, true);  // tiles {0,1,4,5} {2,3,6,7} {8,9,12,13} {10,11,14,15}
    std::vector<uint32_t> core0, core1;
    uint32_t r;
    while (d.next(1, 0, &r)) core1.push_back(r);
    while (d.next(0, 0, &r)) core0.push_back(r);
    EXPECT_EQ(core0, (std::vector<uint32_t>{0, 1, 4, 5, 8, 9, 12, 13}));
    EXPECT_EQ(core1, (std::vector<uint32_t>{2, 3, 6, 7, 10, 11, 14, 15}));
    EXPECT_TRUE(d.empty());
    std::vector<Ray> ao(2);
    d.add_spawned(1, ao, 10);
    EXPECT_FALSE(d.empty());
    EXPECT_FALSE(d.next(0, 100, &r));  // core 0 has nothing: the rays are core 1's
    EXPECT_EQ(d.next_ready_ps(0), UINT64_MAX);
    EXPECT_EQ(d.next_ready_ps(1), 10u);
    EXPECT_FALSE(d.next(1, 5, &r));  // not ready yet
    ASSERT_TRUE(d.next(1, 10, &r));
    EXPECT_EQ(r, 16u);
    d.restart();
    EXPECT_EQ(d.rays().size(), 16u);
    ASSERT_TRUE(d.next(1, 0, &r));
    EXPECT_EQ(r, 2u);  // a new frame deals the tiles again
  }
  {
    p.dynamic = true;
    RayDispatcher d(p, primaries(4, 4), 4, 4, true);
    std::vector<uint32_t> core0, core1;
    uint32_t r;
    while (d.next(0, 0, &r)) core0.push_back(r);  // core 0 asks first and takes all it can
    EXPECT_EQ(core0.size(), 16u);
    EXPECT_FALSE(d.next(1, 0, &r));
    EXPECT_TRUE(d.empty());
  }
  {
    RayDispatcher d(p, primaries(4, 4), 4, 4, true);
    uint32_t r;
    ASSERT_TRUE(d.next(1, 0, &r));  // core 1 asks first: it takes the first tile
    EXPECT_EQ(r, 0u);
    ASSERT_TRUE(d.next(0, 0, &r));
    EXPECT_EQ(r, 2u);  // core 0 the second
    ASSERT_TRUE(d.next(1, 0, &r));
    EXPECT_EQ(r, 1u);  // core 1 finishes its own tile first
  }
}

TEST(SimDispatch, OneCoreIssuesTheSingleOrderWhateverTheDispatchMode) {
  for (bool dynamic : {false, true}) {
    IssuePolicy p = policy(IssuePolicy::Order::Morton, 2, 2);
    p.dynamic = dynamic;
    RayDispatcher one(p, primaries(8, 8), 8, 8, true);
    std::vector<uint32_t> expected = pixel_issue_order(8, 8, p);
    EXPECT_EQ(drain(one), expected);
  }
}
