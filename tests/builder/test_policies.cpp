// The policies over the weighted-SAH core (osah, aobvh, sbvh) and the separate
// builders (median, embree, embree-sbvh): validity, equal-weights equivalence,
// thread-count determinism and the hard cases.
#include <rtsim/builder/build.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/builder/occlusion.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/procedural.h>

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "builder/scene_fixtures.h"

namespace rtsim {
namespace {

using test::same_tree;

void expect_valid(const Bvh& bvh, const Scene& scene, const BuildParams& params) {
  const BvhValidation v = validate_bvh(bvh, scene, limits_for(params));
  EXPECT_TRUE(v.ok()) << params.builder << " on " << scene.name << ":\n" << v.summary();
}

Bvh build(const Scene& scene, const std::string& builder, BuildReport* report = nullptr) {
  BuildParams p;
  p.builder = builder;
  return build_bvh(scene, p, report);
}

TEST(Policies, EveryBuilderGivesValidTreesOnCornellAndSoup) {
  const Scene scenes[] = {make_procedural_scene("cornell"), test::triangle_soup(5000, 3, 0.2f)};
  for (const Scene& scene : scenes)
    for (const std::string& builder : builder_names()) {
      BuildParams p;
      p.builder = builder;
      BuildReport report;
      const Bvh bvh = build_bvh(scene, p, &report);
      expect_valid(bvh, scene, p);
      EXPECT_EQ(report.builder, builder);
      EXPECT_GE(report.references, scene.triangle_count()) << builder;
    }
}

TEST(Policies, HardCasesGiveValidTreesForEveryBuilder) {
  const Scene scenes[] = {test::one_centroid_scene(64), test::coplanar_scene(300),
                          test::one_point_scene(37), test::zero_area_scene(300),
                          test::triangle_soup(1)};
  for (const Scene& scene : scenes)
    for (const std::string& builder : builder_names()) {
      BuildParams p;
      p.builder = builder;
      expect_valid(build_bvh(scene, p), scene, p);
    }
}

TEST(Policies, EqualOcclusionValuesGiveExactlyTheSahTree) {
  const Scene scene = test::triangle_soup(20000, 9, 0.1f);
  const Bvh sah = build(scene, "sah");
  const size_t n = scene.triangle_count();
  // All equal (any value, including all 0 and all 1), and all NaN (sanitised to 1).
  for (float value : {0.0f, 0.37f, 1.0f, std::numeric_limits<float>::quiet_NaN()}) {
    for (float floor : {0.0f, 0.05f}) {
      BuildParams p;
      p.builder = "aobvh";
      p.ao_weight_floor = floor;
      p.occlusion_values.assign(n, value);
      BuildReport report;
      const Bvh ao = build_bvh(scene, p, &report);
      EXPECT_TRUE(same_tree(ao, sah)) << "value " << value << " floor " << floor;
      EXPECT_EQ(report.sanitised_values, std::isnan(value) ? n : 0u);
    }
  }
}

TEST(Policies, EqualOcclusionValuesGiveExactlyTheSbvhTreeWithSpatialSplits) {
  // aosbvh = the AO-BVH weights on the SBVH policy: equal weights must reduce it to sbvh.
  const Scene scene = test::triangle_soup(20000, 9, 0.1f);
  const Bvh sbvh = build(scene, "sbvh");
  for (float value : {0.0f, 0.37f, 1.0f}) {
    BuildParams p;
    p.builder = "aosbvh";
    p.occlusion_values.assign(scene.triangle_count(), value);
    EXPECT_TRUE(same_tree(build_bvh(scene, p), sbvh)) << "value " << value;
  }
  // Unequal values change it, and it stays within the SBVH reference budget.
  BuildParams p;
  p.builder = "aosbvh";
  p.occlusion_values.resize(scene.triangle_count());
  for (size_t i = 0; i < p.occlusion_values.size(); ++i)
    p.occlusion_values[i] = scene.triangle_bounds(uint32_t(i)).centre().x < 0.3f ? 0.0f : 1.0f;
  const Bvh weighted = build_bvh(scene, p);
  EXPECT_FALSE(same_tree(weighted, sbvh));
  expect_valid(weighted, scene, p);
}

TEST(Policies, UnequalWeightsChangeTheTree) {
  const Scene scene = test::triangle_soup(5000, 9, 0.1f);
  BuildParams p;
  p.builder = "aobvh";
  p.occlusion_values.resize(scene.triangle_count());
  for (size_t i = 0; i < p.occlusion_values.size(); ++i)
    p.occlusion_values[i] = scene.triangle_bounds(uint32_t(i)).centre().x < 0.3f ? 0.0f : 1.0f;
  const Bvh ao = build_bvh(scene, p);
  expect_valid(ao, scene, p);
  EXPECT_FALSE(same_tree(ao, build(scene, "sah")));
}

TEST(Policies, ZeroFloorWithOccludedHalfStaysWithinLimits) {
  // Weight 0 regions cost nothing: without a floor the builder must still end.
  const Scene scene = test::triangle_soup(4000, 4, 0.1f);
  BuildParams p;
  p.builder = "aobvh";
  p.ao_weight_floor = 0.0f;
  p.occlusion_values.assign(scene.triangle_count(), 0.0f);
  for (size_t i = 0; i < p.occlusion_values.size(); i += 2) p.occlusion_values[i] = 1.0f;
  expect_valid(build_bvh(scene, p), scene, p);
}

TEST(Policies, EstimatedOcclusionAndVisibilityOnCornell) {
  const Scene scene = make_procedural_scene("cornell");
  BuildReport ao_report, osah_report;
  BuildParams p;
  p.builder = "aobvh";
  expect_valid(build_bvh(scene, p, &ao_report), scene, p);
  EXPECT_GT(ao_report.mean_occlusion, 0.0);
  EXPECT_LT(ao_report.mean_occlusion, 1.0);
  EXPECT_EQ(ao_report.ao_rays, scene.triangle_count() * p.ao_rays);
  ASSERT_EQ(ao_report.weights.size(), scene.triangle_count());
  p.builder = "osah";
  p.camera = scene.cameras.front().name;
  expect_valid(build_bvh(scene, p, &osah_report), scene, p);
  EXPECT_GT(osah_report.visible_triangles, 0u);
  EXPECT_LE(osah_report.visible_triangles, scene.triangle_count());
}

TEST(Policies, OcclusionValuesAreDeterministicAndMeaningful) {
  // A floor with a low ceiling above one half: triangles of the floor under the
  // ceiling are occluded, the ceiling's top side is open.
  Scene scene = test::empty_scene("sandwich");
  for (int i = 0; i < 20; ++i) {
    const float x = float(i) / 20.0f;
    test::add_triangle(scene, vec3(x, 0, 0), vec3(x + 0.05f, 0, 0), vec3(x, 0, 0.05f) + vec3(0, 0, 0));
  }
  // Floor triangles face -y with this winding; flip so they face +y (towards the ceiling).
  for (auto& t : scene.triangles) std::swap(t.y, t.z);
  test::add_triangle(scene, vec3(-1, 0.01f, -1), vec3(0.5f, 0.01f, 2), vec3(0.5f, 0.01f, -1));
  EmbreeScene embree(scene);
  OcclusionParams params;
  params.cutoff = 0.5f;
  params.rays = 16;
  const std::vector<float> a = estimate_occlusion(scene, embree, params);
  const std::vector<float> b = estimate_occlusion(scene, embree, params);
  EXPECT_EQ(a, b);
  EXPECT_LT(a[0], 0.2f);   // under the ceiling at x ~ 0
  EXPECT_GT(a[19], 0.9f);  // x ~ 0.95: open sky
}

TEST(Policies, EmbreesFastTreeGivesTheSameOcclusionValues) {
  // The AO pass casts through Embree's low-quality tree: it must not change the values.
  for (const char* name : {"cornell", "interior"}) {
    const Scene scene = make_procedural_scene(name);
    OcclusionParams params;
    params.cutoff = scene.ao_cutoff();
    params.rays = 4;
    const EmbreeScene oracle(scene), fast(scene, EmbreeScene::Quality::fast);
    EXPECT_EQ(estimate_occlusion(scene, oracle, params), estimate_occlusion(scene, fast, params)) << name;
  }
}

// A thin slab over the ground: its top faces open sky, its bottom faces the ground
// just below. Both sides are dense grids of small triangles in the same cells.
Scene slab_over_ground(int cells) {
  Scene scene = test::empty_scene("slab");
  const float step = 1.0f / float(cells);
  for (int i = 0; i < cells; ++i)
    for (int j = 0; j < cells; ++j) {
      const float x = i * step, y = j * step;
      test::add_triangle(scene, vec3(x, y, 0), vec3(x + step, y, 0), vec3(x, y + step, 0));  // top: +z
      test::add_triangle(scene, vec3(x, y, -0.002f), vec3(x, y + step, -0.002f), vec3(x + step, y, -0.002f));  // bottom: -z
    }
  test::add_triangle(scene, vec3(-20, -20, -0.03f), vec3(20, -20, -0.03f), vec3(0, 20, -0.03f));  // ground, +z
  return scene;
}

TEST(Policies, SharedOcclusionPoolsOnlyLikeFacingNeighbours) {
  const Scene scene = slab_over_ground(64);
  const size_t per_side = 64 * 64;
  const EmbreeScene embree(scene, EmbreeScene::Quality::fast);
  OcclusionParams params;
  params.cutoff = 0.5f;
  params.rays = 16;
  uint64_t per_triangle_rays = 0, shared_rays = 0;
  const std::vector<float> single = estimate_occlusion(scene, embree, params, &per_triangle_rays);
  EXPECT_EQ(per_triangle_rays, scene.triangle_count() * params.rays);
  params.share = 64;
  const std::vector<float> shared = estimate_occlusion(scene, embree, params, &shared_rays);
  EXPECT_LT(shared_rays * 8, per_triangle_rays);  // fewer rays by about the group size
  size_t top_distinct = 0;
  for (size_t i = 0; i < per_side; ++i) {
    const size_t top = 2 * i, bottom = 2 * i + 1;
    EXPECT_GT(shared[top], 0.95f) << top;      // open sky, never pooled with the bottom
    EXPECT_LT(shared[bottom], 0.35f) << bottom;  // the ground 2.8% of the cutoff below
    EXPECT_GT(single[top], 0.95f);
    EXPECT_LT(single[bottom], 0.35f);
    top_distinct += i == 0 || shared[top] != shared[top - 2];
  }
  EXPECT_LT(top_distinct, per_side / 4);  // neighbours did share their estimates
  // The groups and the rays do not depend on the thread count.
  std::vector<float> one_thread;
  tbb::task_arena(1).execute([&] { one_thread = estimate_occlusion(scene, embree, params); });
  EXPECT_EQ(one_thread, shared);
}

TEST(Policies, CoreBuildersAreBitIdenticalForAnyThreadCount) {
  const Scene scene = test::triangle_soup(40000, 5, 0.08f);
  for (const char* builder : {"sbvh", "osah", "aobvh"}) {
    BuildParams p;
    p.builder = builder;
    p.ao_rays = 4;
    p.threads = 1;
    const Bvh one = build_bvh(scene, p);
    p.threads = 2;
    const Bvh two = build_bvh(scene, p);
    EXPECT_TRUE(same_tree(one, two)) << builder;
  }
}

TEST(Policies, SbvhSplitsReferencesWithinTheBudget) {
  // Long thin diagonal triangles overlap a lot: spatial splits pay off.
  Scene scene = test::empty_scene("slivers");
  for (uint32_t i = 0; i < 2000; ++i) {
    KeyedRng rng(2, {i});
    const vec3 a(rng.next_float(), rng.next_float(), rng.next_float());
    const vec3 b(rng.next_float(), rng.next_float(), rng.next_float());
    test::add_triangle(scene, a, b, a + vec3(0.01f, 0.0f, 0.0f));
  }
  BuildParams p;
  p.builder = "sbvh";
  BuildReport report;
  const Bvh bvh = build_bvh(scene, p, &report);
  expect_valid(bvh, scene, p);
  EXPECT_GT(report.spatial_splits, 0u);
  EXPECT_GT(bvh.prim_refs.size(), scene.triangle_count());
  EXPECT_LE(double(bvh.prim_refs.size()), double(p.sbvh_reference_budget) * double(scene.triangle_count()));
  // A smaller budget holds too.
  p.sbvh_reference_budget = 1.1f;
  const Bvh small = build_bvh(scene, p);
  expect_valid(small, scene, p);
  EXPECT_LE(double(small.prim_refs.size()), 1.1 * double(scene.triangle_count()));
  // With budget 1 there is no room for any split reference.
  p.sbvh_reference_budget = 1.0f;
  const Bvh tight = build_bvh(scene, p);
  expect_valid(tight, scene, p);
  EXPECT_EQ(tight.prim_refs.size(), scene.triangle_count());
}

TEST(Policies, SbvhIsNoDearerThanSahOnInteriorAndThreadCountFree) {
  // On interior a spatial split at the root is the cheaper greedy choice but gives a
  // dearer tree than the plain SAH (87.8 vs 86.2 before the root was built both
  // ways). sbvh must never lose to sah there, and the rebuild must not depend on the
  // thread count.
  const Scene scene = make_procedural_scene("interior");
  BuildParams p;
  p.builder = "sah";
  const double sah = sah_cost(build_bvh(scene, p), p.t1, p.t2);
  p.builder = "sbvh";
  p.threads = 1;
  BuildReport report;
  const Bvh one = build_bvh(scene, p, &report);
  expect_valid(one, scene, p);
  EXPECT_GT(report.spatial_splits, 0u);
  EXPECT_LT(sah_cost(one, p.t1, p.t2), sah);
  p.threads = 2;
  EXPECT_TRUE(same_tree(one, build_bvh(scene, p)));
}

TEST(Policies, TreeletRestructuringLowersTheCostAndKeepsEveryTriangle) {
  // On interior the greedy top-down sbvh costs 82.7 and the restructured one 80.5
  // (measured): the pass must lower the cost, make no leaf deeper, keep every
  // triangle, add no reference, keep leaves within their size (also when it merges
  // them), and not depend on the threads.
  const Scene scene = make_procedural_scene("interior");
  auto triangles_of = [](const Bvh& bvh) {
    std::vector<uint32_t> t = bvh.prim_refs;
    std::sort(t.begin(), t.end());
    t.erase(std::unique(t.begin(), t.end()), t.end());
    return t;
  };
  auto height_of = [](const Bvh& bvh) {
    std::vector<uint32_t> depth(bvh.nodes.size(), 0);
    uint32_t most = 0;
    for (size_t i = 0; i < bvh.nodes.size(); ++i) {
      most = std::max(most, depth[i]);
      const BvhNode& n = bvh.nodes[i];
      for (uint32_t c = 0; !n.is_leaf() && c < n.children; ++c) depth[n.index + c] = depth[i] + 1;
    }
    return most;
  };
  BuildParams p;
  p.builder = "sbvh";
  for (uint32_t max_leaf : {4u, 8u}) {
    p.max_leaf_size = max_leaf;
    p.treelet_passes = 0;
    BuildReport greedy_report, report;
    const Bvh greedy = build_bvh(scene, p, &greedy_report);
    EXPECT_EQ(greedy_report.treelets_restructured, 0u);
    p.treelet_passes = 2;
    p.threads = 1;
    const Bvh one = build_bvh(scene, p, &report);
    EXPECT_GT(report.treelets_restructured, 0u);
    expect_valid(one, scene, p);
    EXPECT_LT(sah_cost(one, p.t1, p.t2), 0.985 * sah_cost(greedy, p.t1, p.t2)) << max_leaf;
    EXPECT_LE(height_of(one), height_of(greedy)) << max_leaf;
    EXPECT_EQ(triangles_of(one), triangles_of(greedy)) << max_leaf;
    EXPECT_LE(one.prim_refs.size(), greedy.prim_refs.size()) << max_leaf;
    p.threads = 2;
    EXPECT_TRUE(same_tree(one, build_bvh(scene, p))) << max_leaf;
  }
}

}  // namespace
}  // namespace rtsim
