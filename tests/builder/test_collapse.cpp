// The collapse pass: binary trees of every builder made 4-, 6- and 8-wide with
// the builder's own cost model.
#include <rtsim/builder/build.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/collapse.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "scene_fixtures.h"

namespace rtsim {
namespace {

BuildParams params_for(const std::string& builder, uint32_t width, uint32_t leaf = 4) {
  BuildParams p;
  p.builder = builder;
  p.width = width;
  p.max_leaf_size = leaf;
  p.threads = 1;
  return p;
}

TEST(Collapse, EveryBuilderAndWidthGivesAValidTreeWithinTheFormatsLimits) {
  const Scene scene = test::triangle_soup(3000);
  for (const std::string builder : {"sah", "sbvh", "median", "aobvh", "embree", "embree-sbvh"})
    for (uint32_t width : {4u, 6u, 8u}) {
      SCOPED_TRACE(builder + " width " + std::to_string(width));
      BuildParams p = params_for(builder, width, width == 8 ? 3 : 4);
      p.ao_rays = 4;
      const Bvh bvh = build_bvh(scene, p);
      const BvhValidation v = validate_bvh(bvh, scene, limits_for(p));
      EXPECT_TRUE(v.ok()) << v.summary();
      EXPECT_LE(bvh.width(), width);
      EXPECT_GT(bvh.width(), 2u);  // the collapse used the width it was given
    }
}

TEST(Collapse, ItsCostIsTheWideTreesSahCostAndNoMoreThanTheBinaryTrees) {
  const Scene scene = test::triangle_soup(4000, 11);
  BuildParams p = params_for("sah", 2);
  const Bvh binary = build_bvh(scene, p);
  const double binary_cost = sah_cost(binary, p.t1, p.t2);
  double previous = binary_cost;
  for (uint32_t width : {2u, 4u, 8u}) {
    SCOPED_TRACE(width);
    CollapseParams cp;
    cp.width = width;
    cp.max_leaf_size = 4;
    CollapseReport report;
    const Bvh wide = collapse_bvh(binary, cp, &report);
    const double cost = sah_cost(wide, p.t1, p.t2);
    EXPECT_NEAR(report.cost, cost, 1e-9 * cost);
    // The binary tree is one of the trees the DP chooses among, and a wider
    // node can hold everything a narrower one can.
    EXPECT_LE(cost, previous * (1 + 1e-12));
    previous = cost;
    EXPECT_LE(wide.nodes.size(), binary.nodes.size());
  }
  EXPECT_LT(previous, 0.8 * binary_cost);  // 8-wide visits far fewer nodes
}

TEST(Collapse, WeightedCostIsWhatTheCollapseMinimisesForAnAoTree) {
  const Scene scene = test::triangle_soup(2000, 5);
  BuildParams p = params_for("aobvh", 2);
  p.ao_rays = 8;
  BuildReport r;
  const Bvh binary = build_bvh(scene, p, &r);
  ASSERT_EQ(r.weights.size(), scene.triangle_count());
  CollapseParams cp;
  cp.width = 8;
  cp.max_leaf_size = 4;
  cp.weights = r.weights;
  CollapseReport weighted, plain;
  const Bvh wide = collapse_bvh(binary, cp, &weighted);
  EXPECT_NEAR(weighted.cost, sah_cost(wide, p.t1, p.t2, r.weights), 1e-9 * weighted.cost);
  // Without the weights the same binary tree collapses to a tree that is worse
  // in the weighted cost (or equal): the weights steer the collapse.
  CollapseParams unweighted = cp;
  unweighted.weights.clear();
  const Bvh plain_wide = collapse_bvh(binary, unweighted, &plain);
  EXPECT_LE(sah_cost(wide, p.t1, p.t2, r.weights),
            sah_cost(plain_wide, p.t1, p.t2, r.weights) * (1 + 1e-12));
}

TEST(Collapse, AoTreeWithEqualWeightsCollapsesToTheSahTreesCollapse) {
  const Scene scene = test::triangle_soup(2500, 3);
  for (uint32_t width : {4u, 8u}) {
    BuildParams sah = params_for("sah", width, width == 8 ? 3 : 4);
    BuildParams ao = sah;
    ao.builder = "aobvh";
    ao.occlusion_values.assign(scene.triangle_count(), 0.5f);
    const Bvh a = build_bvh(scene, sah);
    const Bvh b = build_bvh(scene, ao);
    EXPECT_EQ(bvh_content_hash(a), bvh_content_hash(b)) << "width " << width;
    EXPECT_EQ(a.nodes.size(), b.nodes.size());
  }
}

TEST(Collapse, SameTreeWhateverTheThreadCount) {
  const Scene scene = test::triangle_soup(6000, 9);
  for (const std::string builder : {"sah", "sbvh"}) {
    BuildParams one = params_for(builder, 8, 3), two = one;
    two.threads = 2;
    EXPECT_EQ(bvh_content_hash(build_bvh(scene, one)), bvh_content_hash(build_bvh(scene, two)))
        << builder;
  }
}

TEST(Collapse, EveryTriangleStaysReachableInHardCases) {
  // All centroids equal, one triangle, two triangles, flat geometry.
  for (const Scene& scene : {test::one_centroid_scene(300), test::triangle_soup(1), test::triangle_soup(2),
                             test::triangle_soup(500, 4, 0.0f)}) {
    for (uint32_t width : {4u, 6u, 8u}) {
      BuildParams p = params_for("sah", width, 3);
      const Bvh bvh = build_bvh(scene, p);
      const BvhValidation v = validate_bvh(bvh, scene, limits_for(p));
      EXPECT_TRUE(v.ok()) << scene.name << " width " << width << ": " << v.summary();
    }
  }
}

TEST(Collapse, RefusesLeavesLargerThanTheFormatAndBadWidths) {
  const Scene scene = test::triangle_soup(200);
  const Bvh binary = build_bvh(scene, params_for("sah", 2, 8));
  CollapseParams cp;
  cp.width = 8;
  cp.max_leaf_size = 3;
  try {
    collapse_bvh(binary, cp);
    bool any_big = false;
    for (const BvhNode& n : binary.nodes) any_big |= n.count > 3;
    EXPECT_FALSE(any_big) << "a leaf of more than 3 triangles was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("max_leaf_size"), std::string::npos) << e.what();
  }
  cp.width = 9;
  EXPECT_THROW(collapse_bvh(binary, cp), InputError);
  BuildParams bad = params_for("sah", 1);
  EXPECT_THROW(build_bvh(scene, bad), InputError);
}

TEST(Collapse, WideTreesSurviveTheirFile) {
  const Scene scene = test::triangle_soup(800);
  const BuildParams p = params_for("sah", 6);
  const Bvh bvh = build_bvh(scene, p);
  const auto path = std::filesystem::temp_directory_path() / "rtsim_test_collapse_wide.bvh";
  save_bvh(path, bvh, scene, p);
  BvhFileHeader header;
  const Bvh back = load_bvh(path, &scene, &header);
  std::filesystem::remove(path);
  EXPECT_EQ(bvh_content_hash(back), bvh_content_hash(bvh));
  EXPECT_EQ(back.width(), bvh.width());
  EXPECT_NE(header.params_json.find("\"width\":6"), std::string::npos) << header.params_json;
}

}  // namespace
}  // namespace rtsim
