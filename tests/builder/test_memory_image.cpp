// The memory image: regions, record order, triangle storage and packing, and
// the property it exists for: no address depends on the input file's face order.
#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/procedural.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <set>

#include "builder/scene_fixtures.h"

namespace rtsim {
namespace {

std::vector<uint32_t> depth_first(const Bvh& bvh) {
  std::vector<uint32_t> out, stack{0};
  while (!stack.empty()) {
    const uint32_t n = stack.back();
    stack.pop_back();
    out.push_back(n);
    if (!bvh.nodes[n].is_leaf()) stack.push_back(bvh.nodes[n].index + 1), stack.push_back(bvh.nodes[n].index);
  }
  return out;
}

std::vector<uint32_t> breadth_first(const Bvh& bvh) {
  std::vector<uint32_t> out;
  std::deque<uint32_t> queue{0};
  while (!queue.empty()) {
    const uint32_t n = queue.front();
    queue.pop_front();
    out.push_back(n);
    if (!bvh.nodes[n].is_leaf()) queue.push_back(bvh.nodes[n].index), queue.push_back(bvh.nodes[n].index + 1);
  }
  return out;
}

bool triangle_less(const Scene& s, uint32_t a, uint32_t b) { return triangle_geometric_less(s, a, b); }

TEST(MemoryImage, RegionsAreAlignedAndDisjoint) {
  const Scene scene = test::triangle_soup(1000);
  const Bvh bvh = build_bvh(scene, BuildParams{});
  for (const std::string layout : {"bvh2-64", "bvh2-32"})
    for (TriangleStorage storage : {TriangleStorage::Indexed, TriangleStorage::Inline}) {
      MemoryLayoutConfig config;
      config.node_format = layout;
      config.triangle_storage = storage;
      config.triangle_bytes = 48;
      config.base_address = 0x1234;
      const MemoryImage image(scene, bvh, config);
      EXPECT_EQ(image.node_bytes(), layout == "bvh2-64" ? 64u : 32u);
      for (uint64_t base : {image.nodes_base(), image.prim_refs_base(), image.triangles_base()})
        EXPECT_EQ(base % config.region_alignment, 0u);
      EXPECT_GE(image.nodes_base(), config.base_address);
      const MemoryFootprint& f = image.footprint();
      EXPECT_GE(image.prim_refs_base(), image.nodes_base() + f.node_bytes);
      EXPECT_GE(image.triangles_base(), image.prim_refs_base() + f.prim_ref_bytes);
      EXPECT_EQ(image.end_address(), image.triangles_base() + f.triangle_bytes);
      EXPECT_EQ(f.prim_ref_bytes, storage == TriangleStorage::Indexed ? 4u * bvh.prim_refs.size() : 0u);
      for (uint32_t n = 0; n < bvh.nodes.size(); ++n)
        if (image.has_record(n)) {
          EXPECT_GE(image.node_address(n), image.nodes_base());
          EXPECT_LT(image.node_address(n), image.nodes_base() + f.node_bytes);
        }
      for (uint32_t s = 0; s < image.slot_count(); ++s) {
        EXPECT_GE(image.slot_address(s), image.triangles_base());
        EXPECT_LE(image.slot_address(s) + 48, image.end_address());
      }
      EXPECT_NE(image.describe().find("triangles"), std::string::npos);
    }
}

TEST(MemoryImage, LeavesTakeNoNodeSlotWhereTheParentHoldsThem) {
  const Scene scene = test::triangle_soup(2000);
  const Bvh bvh = build_bvh(scene, BuildParams{});
  uint64_t inner = 0;
  for (const BvhNode& n : bvh.nodes) inner += n.is_leaf() ? 0 : 1;
  MemoryLayoutConfig config;
  const MemoryImage wide(scene, bvh, config);
  EXPECT_EQ(wide.footprint().node_records, inner);
  for (uint32_t n = 0; n < bvh.nodes.size(); ++n) EXPECT_EQ(wide.has_record(n), !bvh.nodes[n].is_leaf());
  config.node_format = "bvh2-32";
  const MemoryImage single(scene, bvh, config);
  EXPECT_EQ(single.footprint().node_records, bvh.nodes.size());
  // A single-leaf tree: its root record is still fetched.
  const Scene one = test::triangle_soup(2);
  const Bvh leaf = build_bvh(one, BuildParams{});
  ASSERT_TRUE(leaf.root().is_leaf());
  EXPECT_TRUE(MemoryImage(one, leaf).has_record(0));
}

TEST(MemoryImage, RecordsAndLeafDataFollowTheNodeOrder) {
  const Scene scene = test::triangle_soup(3000);
  const Bvh bvh = build_bvh(scene, BuildParams{});
  for (NodeOrder order : {NodeOrder::DepthFirst, NodeOrder::BreadthFirst}) {
    MemoryLayoutConfig config;
    config.node_order = order;
    config.node_format = "bvh2-32";
    const MemoryImage image(scene, bvh, config);
    const std::vector<uint32_t> walk = order == NodeOrder::DepthFirst ? depth_first(bvh) : breadth_first(bvh);
    uint64_t expected = image.nodes_base();
    uint32_t slot = 0;
    for (uint32_t n : walk) {
      EXPECT_EQ(image.node_address(n), expected);
      expected += 32;
      if (bvh.nodes[n].is_leaf()) {
        EXPECT_EQ(image.leaf_first(n), slot);
        EXPECT_EQ(image.prim_refs_address(n), image.prim_refs_base() + 4ull * slot);
        slot += bvh.nodes[n].count;
      }
    }
    EXPECT_EQ(slot, image.slot_count());
  }
}

TEST(MemoryImage, LeafTrianglesAreTheTreesInGeometricOrder) {
  const Scene scene = test::triangle_soup(3000);
  const Bvh bvh = build_bvh(scene, BuildParams{});
  const MemoryImage image(scene, bvh);
  for (uint32_t n = 0; n < bvh.nodes.size(); ++n) {
    const BvhNode& node = bvh.nodes[n];
    if (!node.is_leaf()) continue;
    std::multiset<uint32_t> tree(bvh.prim_refs.begin() + node.index, bvh.prim_refs.begin() + node.index + node.count);
    std::multiset<uint32_t> laid_out;
    for (uint32_t k = 0; k < node.count; ++k) {
      laid_out.insert(image.slot_triangle(image.leaf_first(n) + k));
      if (k > 0)
        EXPECT_TRUE(triangle_less(scene, image.slot_triangle(image.leaf_first(n) + k - 1),
                                  image.slot_triangle(image.leaf_first(n) + k)));
    }
    EXPECT_EQ(tree, laid_out);
  }
}

TEST(MemoryImage, IndexedStoresEachTriangleOnceInlineOncePerLeaf) {
  const Scene scene = make_procedural_scene("foliage");
  BuildParams params;
  params.builder = "sbvh";
  const Bvh bvh = build_bvh(scene, params);
  std::set<uint32_t> distinct(bvh.prim_refs.begin(), bvh.prim_refs.end());
  ASSERT_GT(bvh.prim_refs.size(), distinct.size()) << "needs a tree with split references";
  MemoryLayoutConfig config;
  const MemoryImage indexed(scene, bvh, config);
  EXPECT_EQ(indexed.footprint().triangle_records, distinct.size());
  // Records in the order the leaves first reach their triangles.
  std::set<uint32_t> seen;
  uint64_t last = 0;
  for (uint32_t s = 0; s < indexed.slot_count(); ++s) {
    if (!seen.insert(indexed.slot_triangle(s)).second) continue;
    EXPECT_GT(indexed.slot_address(s) + 1, last);
    last = indexed.slot_address(s) + 1;
  }
  config.triangle_storage = TriangleStorage::Inline;
  const MemoryImage in_leaf(scene, bvh, config);
  EXPECT_EQ(in_leaf.footprint().triangle_records, bvh.prim_refs.size());
  EXPECT_EQ(in_leaf.footprint().prim_ref_bytes, 0u);
  for (uint32_t s = 1; s < in_leaf.slot_count(); ++s)
    EXPECT_EQ(in_leaf.slot_address(s), in_leaf.slot_address(s - 1) + 36);
  EXPECT_GT(in_leaf.footprint().triangle_bytes, indexed.footprint().triangle_bytes);
}

TEST(MemoryImage, LinePackingKeepsEveryRecordInOneLine) {
  const Scene scene = test::triangle_soup(2000);
  const Bvh bvh = build_bvh(scene, BuildParams{});
  for (uint32_t bytes : {36u, 48u, 64u}) {
    MemoryLayoutConfig config;
    config.triangle_bytes = bytes;
    const MemoryImage packed(scene, bvh, config);
    config.triangle_packing = TrianglePacking::Line;
    const MemoryImage lined(scene, bvh, config);
    uint64_t packed_straddles = 0;
    for (uint32_t s = 0; s < lined.slot_count(); ++s) {
      EXPECT_EQ(lined.slot_address(s) / 64, (lined.slot_address(s) + bytes - 1) / 64) << bytes;
      packed_straddles += packed.slot_address(s) / 64 != (packed.slot_address(s) + bytes - 1) / 64;
    }
    if (bytes != 64) EXPECT_GT(packed_straddles, 0u) << bytes;
  }
  MemoryLayoutConfig bad;
  bad.triangle_packing = TrianglePacking::Line;
  bad.triangle_bytes = 80;
  EXPECT_THROW(MemoryImage(scene, bvh, bad), InputError);
  bad.triangle_bytes = 20;
  bad.triangle_packing = TrianglePacking::Packed;
  EXPECT_THROW(MemoryImage(scene, bvh, bad), InputError);
}

TEST(MemoryImage, BrokenLinksAreRefusedNamingTheNode) {
  const Scene scene = test::triangle_soup(100);
  Bvh bvh = build_bvh(scene, BuildParams{});
  bvh.nodes[0].index = 0;  // a child before (at) its parent: a cycle
  try {
    MemoryImage image(scene, bvh);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bvh: node 0"), std::string::npos);
  }
}

// The reason the image exists: the same geometry in another face order gives the
// same tree, the same addresses and the same data at every address.
class FaceOrder : public ::testing::TestWithParam<std::string> {};

TEST_P(FaceOrder, ShufflingTheFacesChangesNoAddressAndNoRecord) {
  for (const char* name : {"interior", "foliage"}) {
    const Scene scene = make_procedural_scene(name);
    Scene shuffled = scene;
    shuffle_triangles(shuffled, 12345);
    ASSERT_NE(shuffled.content_hash(), scene.content_hash());
    BuildParams params;
    params.builder = GetParam();
    const Bvh a = build_bvh(scene, params), b = build_bvh(shuffled, params);
    const MemoryImage ia(scene, a), ib(shuffled, b);
    ASSERT_EQ(a.nodes.size(), b.nodes.size()) << name;
    ASSERT_EQ(ia.slot_count(), ib.slot_count()) << name;
    const std::vector<uint32_t> wa = depth_first(a), wb = depth_first(b);
    for (size_t i = 0; i < wa.size(); ++i) {
      const BvhNode &na = a.nodes[wa[i]], &nb = b.nodes[wb[i]];
      ASSERT_EQ(na.count, nb.count) << name << " node " << i;
      ASSERT_EQ(na.bounds.lo, nb.bounds.lo) << name << " node " << i;
      ASSERT_EQ(na.bounds.hi, nb.bounds.hi) << name << " node " << i;
      ASSERT_EQ(ia.has_record(wa[i]), ib.has_record(wb[i]));
      if (ia.has_record(wa[i])) ASSERT_EQ(ia.node_address(wa[i]), ib.node_address(wb[i]));
    }
    for (uint32_t s = 0; s < ia.slot_count(); ++s) {
      ASSERT_EQ(ia.slot_address(s), ib.slot_address(s)) << name << " slot " << s;
      for (int k = 0; k < 3; ++k)
        ASSERT_EQ(scene.vertex(ia.slot_triangle(s), k), shuffled.vertex(ib.slot_triangle(s), k))
            << name << " slot " << s;
    }
  }
}

// Every builder: the sampled ones (AO, visibility, ray samples) key their rays by
// geometry or pixel and see the triangles in geometric order (build_bvh).
INSTANTIATE_TEST_SUITE_P(Builders, FaceOrder, ::testing::ValuesIn(builder_names()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param;
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

}  // namespace
}  // namespace rtsim
