// How the weighted builders turn their per-triangle information into costs:
// the AO-BVH's two weight forms (normalised to mean 1, or the patent's literal
// sum of occlusion values). OSAH's visibility rules: test_osah.cpp.
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

}  // namespace
}  // namespace rtsim
