// The binned / full-sweep SAH builder and the structural validator.
#include <rtsim/builder/build.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/procedural.h>

#include <gtest/gtest.h>

#include "builder/scene_fixtures.h"

namespace rtsim {
namespace {

using test::same_tree;

void expect_valid(const Bvh& bvh, const Scene& scene, const BuildParams& params) {
  const BvhValidation v = validate_bvh(bvh, scene, limits_for(params));
  EXPECT_TRUE(v.ok()) << params.builder << " on " << scene.name << ":\n" << v.summary();
}

TEST(Sah, SoupTreeIsValidForSeveralLeafSizesAndBinCounts) {
  const Scene scene = test::triangle_soup(3000);
  for (uint32_t leaf : {1u, 2u, 4u, 8u}) {
    for (uint32_t bins : {0u, 8u, 32u}) {
      BuildParams p;
      p.max_leaf_size = leaf;
      p.bins = bins;
      const Bvh bvh = build_bvh(scene, p);
      expect_valid(bvh, scene, p);
      for (const BvhNode& n : bvh.nodes) ASSERT_LE(n.count, leaf);
    }
  }
}

TEST(Sah, ProceduralCornellIsValid) {
  const Scene scene = make_procedural_scene("cornell");
  for (const char* builder : {"sah", "median"}) {
    BuildParams p;
    p.builder = builder;
    expect_valid(build_bvh(scene, p), scene, p);
  }
}

TEST(Sah, HardCasesGiveValidTrees) {
  const Scene scenes[] = {test::one_centroid_scene(64), test::coplanar_scene(500),
                          test::one_point_scene(37), test::zero_area_scene(400),
                          test::triangle_soup(1)};
  for (const Scene& scene : scenes) {
    for (const char* builder : {"sah", "median"}) {
      for (uint32_t bins : {0u, 32u}) {
        BuildParams p;
        p.builder = builder;
        p.bins = bins;
        BuildReport report;
        const Bvh bvh = build_bvh(scene, p, &report);
        expect_valid(bvh, scene, p);
      }
    }
  }
}

TEST(Sah, OneCentroidSceneFallsBackToMedianSplits) {
  const Scene scene = test::one_centroid_scene(64);
  BuildParams p;
  BuildReport report;
  const Bvh bvh = build_bvh(scene, p, &report);
  EXPECT_GT(report.median_splits, 0u);
  // 64 triangles, 4 per leaf, balanced: 16 leaves of exactly 4.
  uint32_t leaves = 0;
  for (const BvhNode& n : bvh.nodes) leaves += n.is_leaf() ? 1 : 0;
  EXPECT_EQ(leaves, 16u);
}

TEST(Sah, SingleTriangleIsOneLeaf) {
  const Scene scene = test::triangle_soup(1);
  const Bvh bvh = build_bvh(scene, BuildParams{});
  ASSERT_EQ(bvh.nodes.size(), 1u);
  EXPECT_TRUE(bvh.root().is_leaf());
  EXPECT_EQ(bvh.prim_refs, std::vector<uint32_t>{0});
}

TEST(Sah, NoTriangleIsAnInputError) {
  const Scene scene = test::empty_scene("nothing");
  for (const std::string& builder : builder_names()) {
    BuildParams p;
    p.builder = builder;
    EXPECT_THROW(build_bvh(scene, p), InputError) << builder;
  }
}

TEST(Sah, BadParametersAreInputErrors) {
  const Scene scene = test::triangle_soup(10);
  BuildParams p;
  p.builder = "nonsense";
  EXPECT_THROW(build_bvh(scene, p), InputError);
  p = BuildParams{};
  p.bins = 1;
  EXPECT_THROW(build_bvh(scene, p), InputError);
  p = BuildParams{};
  p.max_leaf_size = 0;
  EXPECT_THROW(build_bvh(scene, p), InputError);
  p = BuildParams{};
  p.t2 = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(build_bvh(scene, p), InputError);
}

TEST(Sah, DepthLimitIsKeptOrRefusedClearly) {
  const Scene scene = test::triangle_soup(3000);  // 750 leaves of 4 need 10 levels
  BuildParams p;
  p.max_depth = 10;
  const Bvh bvh = build_bvh(scene, p);
  const BvhValidation v = validate_bvh(bvh, scene, limits_for(p));
  EXPECT_TRUE(v.ok()) << v.summary();
  EXPECT_LE(v.max_depth, 10u);
  p.max_depth = 9;
  EXPECT_THROW(build_bvh(scene, p), InputError);
}

TEST(Sah, TreeIsBitIdenticalForAnyThreadCount) {
  // Large enough for chunked parallel binning and parallel recursion.
  const Scene scene = test::triangle_soup(60000);
  for (uint32_t bins : {32u, 0u}) {
    BuildParams p;
    p.bins = bins;
    p.threads = 1;
    const Bvh one = build_bvh(scene, p);
    p.threads = 2;
    const Bvh two = build_bvh(scene, p);
    p.threads = 0;
    const Bvh all = build_bvh(scene, p);
    EXPECT_TRUE(same_tree(one, two)) << "bins " << bins;
    EXPECT_TRUE(same_tree(one, all)) << "bins " << bins;
    if (bins == 0) break;  // the sweep is slow; one size is enough
  }
}

TEST(Validator, CatchesBrokenTrees) {
  const Scene scene = test::triangle_soup(200);
  const BuildParams p;
  const Bvh good = build_bvh(scene, p);
  ASSERT_TRUE(validate_bvh(good, scene, limits_for(p)).ok());

  Bvh shrunk = good;  // a child box that no longer holds its subtree
  shrunk.nodes[1].bounds.hi = shrunk.nodes[1].bounds.lo;
  EXPECT_FALSE(validate_bvh(shrunk, scene, limits_for(p)).ok());

  Bvh lost = good;  // a triangle nobody references
  for (BvhNode& n : lost.nodes)
    if (n.is_leaf()) {
      lost.prim_refs[n.index] = lost.prim_refs[n.index == 0 ? 1 : 0];
      break;
    }
  EXPECT_FALSE(validate_bvh(lost, scene, limits_for(p)).ok());

  BvhLimits tight = limits_for(p);  // leaves over the limit
  tight.max_leaf_size = 1;
  EXPECT_FALSE(validate_bvh(good, scene, tight).ok());

  Bvh cyclic = good;  // an inner node pointing back at the root
  cyclic.nodes[1].count = 0;
  cyclic.nodes[1].index = 0;
  EXPECT_FALSE(validate_bvh(cyclic, scene, limits_for(p)).ok());

  Bvh empty_box = good;
  empty_box.nodes[2].bounds = Aabb{};
  EXPECT_FALSE(validate_bvh(empty_box, scene, limits_for(p)).ok());
}

}  // namespace
}  // namespace rtsim
