// How the weighted builders turn their per-triangle information into costs:
// the AO-BVH's two weight forms (normalised to mean 1, or the patent's literal
// sum of occlusion values) and the OSAH's visibility mix.
#include <rtsim/builder/build.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/builder/occlusion.h>
#include <rtsim/builder/validate_bvh.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>

#include "builder/scene_fixtures.h"

namespace rtsim {
namespace {

using test::same_tree;

TEST(WeightForms, LiteralWeightsAreTheFlooredValuesUnscaled) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> values{0.0f, 0.25f, 0.5f, 1.0f, nan, 2.0f};
  uint64_t sanitised = 0;
  const std::vector<float> literal = occlusion_weights(values, 0.5f, &sanitised, false);
  ASSERT_EQ(literal.size(), values.size());
  EXPECT_EQ(sanitised, 2u);  // NaN -> 1, 2 -> 1
  const float expected[] = {0.5f, 0.625f, 0.75f, 1.0f, 1.0f, 1.0f};
  for (size_t i = 0; i < values.size(); ++i) EXPECT_FLOAT_EQ(literal[i], expected[i]) << i;
  // The default form scales the same weights to mean 1.
  const std::vector<float> normalised = occlusion_weights(values, 0.5f);
  const double mean = std::accumulate(normalised.begin(), normalised.end(), 0.0) / values.size();
  EXPECT_NEAR(mean, 1.0, 1e-6);
  for (size_t i = 0; i < values.size(); ++i)
    EXPECT_NEAR(normalised[i] / literal[i], normalised[0] / literal[0], 1e-6) << i;
}

TEST(WeightForms, LiteralFormWithEqualValuesIsSahWithT2ScaledByTheValue) {
  // AO(S) = v * count: the literal cost is the SAH cost with T2' = v * T2, so
  // triangle tests look cheaper and leaves grow. (0.25 is a power of two: the
  // scaled costs are exact, so the trees must be identical.)
  const Scene scene = test::triangle_soup(20000, 11, 0.1f);
  BuildParams ao;
  ao.builder = "aobvh";
  ao.ao_normalise = false;
  ao.ao_weight_floor = 0.0f;
  ao.occlusion_values.assign(scene.triangle_count(), 0.25f);
  ao.max_leaf_size = 16;  // room for the larger leaves the cheaper T2 asks for
  const Bvh literal = build_bvh(scene, ao);
  EXPECT_TRUE(validate_bvh(literal, scene, limits_for(ao)).ok());

  BuildParams sah;
  sah.max_leaf_size = ao.max_leaf_size;
  sah.t2 = 0.25f;
  EXPECT_TRUE(same_tree(literal, build_bvh(scene, sah)));

  // The default (normalised) form of the same values is the plain SAH tree,
  // which has more, smaller leaves.
  ao.ao_normalise = true;
  const Bvh normalised = build_bvh(scene, ao);
  sah.t2 = 1.0f;
  EXPECT_TRUE(same_tree(normalised, build_bvh(scene, sah)));
  EXPECT_LT(literal.nodes.size(), normalised.nodes.size());
}

TEST(WeightForms, LiteralFormWithOpenValuesIsTheSahTree) {
  const Scene scene = test::triangle_soup(8000, 12, 0.1f);
  BuildParams p;
  p.builder = "aobvh";
  p.ao_normalise = false;
  p.ao_weight_floor = 0.0f;
  p.occlusion_values.assign(scene.triangle_count(), 1.0f);
  EXPECT_TRUE(same_tree(build_bvh(scene, p), build_bvh(scene, BuildParams{})));
}

// Visible triangles: those in the slab y < 0.3 of a soup (as if a camera saw
// only that part).
std::vector<uint8_t> slab_visibility(const Scene& scene) {
  std::vector<uint8_t> visible(scene.triangle_count());
  for (size_t i = 0; i < visible.size(); ++i)
    visible[i] = scene.triangle_bounds(uint32_t(i)).centre().y < 0.3f ? 1 : 0;
  return visible;
}

TEST(WeightForms, OsahWithZeroVisibilityWeightIsTheSahTree) {
  const Scene scene = test::triangle_soup(20000, 13, 0.1f);
  BuildParams p;
  p.builder = "osah";
  p.osah_w = 0.0f;
  p.visibility = slab_visibility(scene);
  EXPECT_TRUE(same_tree(build_bvh(scene, p), build_bvh(scene, BuildParams{})));
}

TEST(WeightForms, OsahLowersItsOwnCostAndLiftsVisibleTrianglesTowardsTheRoot) {
  // The OSAH cost P_i = w V_i / V + (1 - w) A_i / A (V, A of the parent) is what
  // the builder minimises: its tree must be cheaper than the SAH tree under that
  // cost, and the visible triangles must sit higher up than in the SAH tree.
  // (Whether that pays off for real rays depends on the scene: see
  // BuildParams::osah_w; on `interior` it does not.)
  const Scene scene = test::triangle_soup(20000, 14, 0.05f);
  BuildParams p;
  p.builder = "osah";
  p.visibility = slab_visibility(scene);
  BuildReport report;
  const Bvh osah = build_bvh(scene, p, &report);
  const Bvh sah = build_bvh(scene, BuildParams{});
  EXPECT_TRUE(validate_bvh(osah, scene, limits_for(p)).ok());
  const double osah_cost = sah_cost(osah, p.t1, p.t2, {}, report.visibility, p.osah_w);
  const double sah_under_osah = sah_cost(sah, p.t1, p.t2, {}, report.visibility, p.osah_w);
  EXPECT_LT(osah_cost, 0.9 * sah_under_osah);

  auto mean_visible_depth = [&](const Bvh& bvh) {
    std::vector<uint32_t> depth(bvh.nodes.size(), 0);
    double sum = 0;
    uint64_t count = 0;
    for (size_t i = 0; i < bvh.nodes.size(); ++i) {
      const BvhNode& n = bvh.nodes[i];
      if (!n.is_leaf()) {
        depth[n.index] = depth[n.index + 1] = depth[i] + 1;
        continue;
      }
      for (uint32_t k = n.index; k < n.index + n.count; ++k)
        if (report.visibility[bvh.prim_refs[k]]) sum += depth[i], ++count;
    }
    return count ? sum / double(count) : 0.0;
  };
  EXPECT_LT(mean_visible_depth(osah), mean_visible_depth(sah) - 0.5);
}

}  // namespace
}  // namespace rtsim
