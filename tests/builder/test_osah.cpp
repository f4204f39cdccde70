// OSAH as Vinkler, Havran and Sochor build it (builders/osah.cpp): what its rules
// reduce to where visibility says nothing, and the visibility split where it does.
#include <rtsim/builder/build.h>
#include <rtsim/builder/validate_bvh.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "builder/scene_fixtures.h"

namespace rtsim {
namespace {

using test::same_tree;

// The depth above which OSAH tries its visibility split: floor(0.5 log2 N).
uint32_t visibility_depth(const Scene& scene) {
  return uint32_t(std::floor(0.5 * std::log2(double(scene.triangle_count()))));
}

// SBVH with spatial splits only from `from_depth` on and no treelet pass: what
// OSAH's rules leave where every triangle is visible (object splits above the
// visibility depth, SBVH below it) or none is (from_depth past the tree: object
// splits only).
Bvh plain_policy(const Scene& scene, uint32_t from_depth) {
  BuildParams p;
  p.builder = "sbvh";
  p.treelet_passes = 0;
  p.sbvh_min_depth = from_depth;
  return build_bvh(scene, p);
}

std::set<uint32_t> triangles_below(const Bvh& bvh, uint32_t node) {
  std::set<uint32_t> out;
  std::vector<uint32_t> stack{node};
  while (!stack.empty()) {
    const BvhNode& n = bvh.nodes[stack.back()];
    stack.pop_back();
    if (n.is_leaf()) {
      out.insert(bvh.prim_refs.begin() + n.index, bvh.prim_refs.begin() + n.index + n.count);
      continue;
    }
    for (uint32_t c = 0; c < n.children; ++c) stack.push_back(n.index + c);
  }
  return out;
}

TEST(Osah, UniformVisibilityGivesThePlainPolicyItsRulesReduceTo) {
  const Scene scene = test::triangle_soup(20000, 9, 0.1f);
  const uint32_t depth = visibility_depth(scene);
  ASSERT_GT(depth, 0u);
  BuildParams p;
  p.builder = "osah";
  p.osah_child_order = "split";  // visible-first would order all-visible children by size
  p.visibility.assign(scene.triangle_count(), 0);
  BuildReport none;
  EXPECT_TRUE(same_tree(build_bvh(scene, p, &none), plain_policy(scene, p.max_depth))) << "none visible";
  EXPECT_EQ(none.visibility_splits, 0u);
  p.visibility.assign(scene.triangle_count(), 1);
  BuildReport all;
  const Bvh all_visible = build_bvh(scene, p, &all);
  EXPECT_TRUE(same_tree(all_visible, plain_policy(scene, depth))) << "all visible";
  EXPECT_EQ(all.visibility_splits, 0u);
  // The policy is not the plain SBVH: its spatial splits near the root are gone.
  EXPECT_FALSE(same_tree(all_visible, plain_policy(scene, 0)));
  // And the weight and the acceptance rule have nothing to act on.
  p.osah_w = 0.2f;
  p.osah_acceptance = "always";
  EXPECT_TRUE(same_tree(build_bvh(scene, p), all_visible));
}

// A small visible cluster beside a long row of hidden triangles. The plain SAH and
// SBVH split the row (their larger child is the row's far part), but the hidden
// child of the visibility split holds the whole row: more references than that
// larger child, so the authors' rule takes the visibility split at the root, with
// the visible cluster first.
Scene cluster_beside_row(std::vector<uint8_t>* visibility) {
  Scene s = test::empty_scene("cluster-beside-row");
  for (uint32_t i = 0; i < 60; ++i) {
    KeyedRng rng(21, {i});
    const vec3 c(0.05f + 0.1f * rng.next_float(), 0.05f + 0.1f * rng.next_float(), 0.05f + 0.1f * rng.next_float());
    test::add_triangle(s, c, c + vec3(0.03f, 0, 0), c + vec3(0, 0.03f, 0.01f));
    visibility->push_back(1);
  }
  for (uint32_t i = 0; i < 600; ++i) {
    const float x = 0.4f + 3.6f * float(i) / 600.0f;
    test::add_triangle(s, vec3(x, 0.0f, 0.0f), vec3(x + 0.004f, 0.2f, 0.0f), vec3(x, 0.1f, 0.2f));
    visibility->push_back(0);
  }
  return s;
}

TEST(Osah, HiddenRowBesideAVisibleClusterIsSplitOffAtTheRoot) {
  std::vector<uint8_t> visibility;
  const Scene scene = cluster_beside_row(&visibility);
  BuildParams p;
  p.builder = "osah";
  p.visibility = visibility;
  BuildReport report;
  const Bvh bvh = build_bvh(scene, p, &report);
  ASSERT_TRUE(validate_bvh(bvh, scene, limits_for(p)).ok());
  ASSERT_FALSE(bvh.root().is_leaf());
  std::set<uint32_t> cluster, row;
  for (uint32_t t = 0; t < scene.triangle_count(); ++t) (visibility[t] ? cluster : row).insert(t);
  EXPECT_EQ(triangles_below(bvh, bvh.root().index), cluster) << "the visible cluster first";
  EXPECT_EQ(triangles_below(bvh, bvh.root().index + 1), row);
  EXPECT_GE(report.visibility_splits, 1u);

  // Without the rule (no levels to try it in) the root splits the row instead.
  p.osah_depth = 0;
  BuildReport plain_report;
  const Bvh plain = build_bvh(scene, p, &plain_report);
  EXPECT_EQ(plain_report.visibility_splits, 0u);
  EXPECT_NE(triangles_below(plain, plain.root().index), cluster);
  EXPECT_NE(triangles_below(plain, plain.root().index + 1), cluster);

  // Mirrored in x the row lies at lower x, on the plane's left: the split's own
  // order puts it first, the authors' visible-first order the cluster.
  Scene mirrored = scene;
  for (vec3& v : mirrored.vertices) v.x = -v.x;
  BuildParams q;
  q.builder = "osah";
  q.visibility = visibility;
  const Bvh visible_first = build_bvh(mirrored, q);
  EXPECT_EQ(triangles_below(visible_first, visible_first.root().index), cluster);
  q.osah_child_order = "split";
  const Bvh split_order = build_bvh(mirrored, q);
  EXPECT_EQ(triangles_below(split_order, split_order.root().index), row);
}

TEST(Osah, HardCasesStayValidUnderEveryRule) {
  const Scene scenes[] = {test::one_centroid_scene(64), test::coplanar_scene(300), test::one_point_scene(37),
                          test::zero_area_scene(300), test::triangle_soup(3000, 5, 0.3f)};
  for (const Scene& scene : scenes)
    for (const char* acceptance : {"authors", "always"})
      for (bool spatial : {true, false}) {
        BuildParams p;
        p.builder = "osah";
        p.osah_acceptance = acceptance;
        p.osah_spatial = spatial;
        p.osah_depth = 2.0f;  // every level of these small trees
        p.visibility.resize(scene.triangle_count());
        for (size_t i = 0; i < p.visibility.size(); ++i) p.visibility[i] = i % 3 == 0;
        const BvhValidation v = validate_bvh(build_bvh(scene, p), scene, limits_for(p));
        EXPECT_TRUE(v.ok()) << scene.name << " " << acceptance << " spatial " << spatial << ":\n" << v.summary();
      }
}

}  // namespace
}  // namespace rtsim
