// The exact referee of validation: exact edge signs, candidates, and its rulings
// on the cases that made `trace --validate` cry wolf .
#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/exact_referee.h>
#include <rtsim/model/core/validate.h>
#include <rtsim/workloads/scene_registry.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace rtsim;

namespace {

Scene one_triangle(vec3 a, vec3 b, vec3 c) {
  Scene s;
  s.name = "tri";
  s.vertices = {a, b, c};
  s.triangles = {uvec3(0, 1, 2)};
  s.material_ids = {0};
  s.materials = {Material{}};
  return s;
}

Ray primary(vec3 o, vec3 d) {
  Ray r;
  r.origin = o;
  r.direction = d;
  r.type = RayType::Primary;
  return r;
}

}  // namespace

// A ray through an edge of a triangle gives an exact zero; the next float over
// on either side gives the two signs. A double evaluation alone cannot tell
// these apart once the coordinates are large.
TEST(ExactReferee, EdgeSignIsExactAtAndBesideAnEdge) {
  const vec3 p(1e7f, 0.0f, 0.0f), q(1e7f, 1.0f, 0.0f);
  const vec3 d(0.0f, 0.0f, 1.0f);
  EXPECT_EQ(exact_edge_sign(vec3(1e7f, 0.5f, -1.0f), d, p, q), 0);
  const float beside_plus = std::nextafter(1e7f, 2e7f), beside_minus = std::nextafter(1e7f, 0.0f);
  const int plus = exact_edge_sign(vec3(beside_plus, 0.5f, -1.0f), d, p, q);
  const int minus = exact_edge_sign(vec3(beside_minus, 0.5f, -1.0f), d, p, q);
  EXPECT_NE(plus, 0);
  EXPECT_EQ(minus, -plus);
  // Antisymmetric in the edge's direction, as the core's edge functions are.
  EXPECT_EQ(exact_edge_sign(vec3(beside_plus, 0.5f, -1.0f), d, q, p), -plus);
}

// The exact sign where every double term cancels: the true determinant is far
// below the double rounding of its terms (origin far away, a tiny offset).
TEST(ExactReferee, EdgeSignSurvivesCancellation) {
  const vec3 o(3e6f, -2e6f, 1e6f);
  const vec3 p(3e6f + 0.25f, -2e6f, 1e6f + 7.0f), q(3e6f + 0.25f, -2e6f + 1.0f, 1e6f + 7.0f);
  // d in the plane x = const through the edge: exactly zero.
  EXPECT_EQ(exact_edge_sign(o, vec3(0.25f, 0.0f, 7.0f), p, q), 0);
  // One float step of d.x to either side decides it.
  EXPECT_EQ(exact_edge_sign(o, vec3(std::nextafter(0.25f, 1.0f), 0.0f, 7.0f), p, q),
            -exact_edge_sign(o, vec3(std::nextafter(0.25f, 0.0f), 0.0f, 7.0f), p, q));
}

// Candidates: inside, outside, and on the boundary (a hit that may be missed).
TEST(ExactReferee, CandidatesAreInsideOutsideOrOnTheBoundary) {
  const Scene scene = one_triangle(vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0));
  const ExactReferee referee(scene, 1e-4f, 0.0f);
  const auto inside = referee.candidates(primary(vec3(0.25f, 0.25f, 1), vec3(0, 0, -1)));
  ASSERT_EQ(inside.size(), 1u);
  EXPECT_TRUE(inside[0].required());
  EXPECT_NEAR(double(inside[0].t), 1.0, 1e-12);
  EXPECT_TRUE(referee.candidates(primary(vec3(0.75f, 0.75f, 1), vec3(0, 0, -1))).empty());
  const auto on_edge = referee.candidates(primary(vec3(0.5f, 0.0f, 1), vec3(0, 0, -1)));
  ASSERT_EQ(on_edge.size(), 1u);
  EXPECT_TRUE(on_edge[0].on_boundary);
  // So on the edge both a hit and a miss are admissible; inside only the hit.
  const Ray edge_ray = primary(vec3(0.5f, 0.0f, 1), vec3(0, 0, -1));
  EXPECT_TRUE(referee.admissible(edge_ray, on_edge, {false, 0.0f, kNoPrim}));
  EXPECT_TRUE(referee.admissible(edge_ray, on_edge, {true, 1.0f, 0}));
  const Ray inside_ray = primary(vec3(0.25f, 0.25f, 1), vec3(0, 0, -1));
  EXPECT_FALSE(referee.admissible(inside_ray, inside, {false, 0.0f, kNoPrim}));
  EXPECT_FALSE(referee.admissible(inside_ray, inside, {true, 2.0f, 0}));  // wrong distance
  EXPECT_TRUE(referee.admissible(inside_ray, inside, {true, 1.0f, 0}));
}

// The case: on the built-in cornell scene at 64x64 one primary ray is
// hit by Embree on a box corner (t = 3.035) that it misses by about 3e-8, and hit
// by the core on the wall behind (t = 4.557). The referee rules Embree wrong, and
// the core right, so validation passes.
TEST(ExactReferee, CornellCornerRayIsEmbreeWrong) {
  const Scene scene = load_scene("cornell");
  Ray r = primary(vec3(0.0f, 0.0f, 3.4000001f), vec3(0.21413967f, -0.148250535f, -0.965487421f));
  const ExactReferee referee(scene, 1e-4f, 1e-6f * scene.diagonal());
  const auto found = referee.candidates(r);
  const EmbreeScene embree(scene);
  const EmbreeHit e = embree.intersect(r.origin, r.direction, r.tmin, r.tmax);
  ASSERT_TRUE(e.hit);
  bool embree_prim_required = false;
  for (const RefereeCandidate& c : found) embree_prim_required |= c.prim == e.prim && c.required();
  EXPECT_FALSE(embree_prim_required) << "Embree's prim " << e.prim << " at t=" << e.t;
  EXPECT_FALSE(referee.admissible(r, found, {true, e.t, e.prim}));
  // Whatever the core answers here must be the nearest required candidate.
  const RefereeCandidate* nearest = nullptr;
  for (const RefereeCandidate& c : found)
    if (c.required() && (!nearest || c.t < nearest->t)) nearest = &c;
  ASSERT_NE(nearest, nullptr);
  EXPECT_NEAR(double(nearest->t), 4.5572834, 1e-4);
  EXPECT_TRUE(referee.admissible(r, found, {true, float(nearest->t), nearest->prim}));
}

// Validation with the referee over whole frames: every disagreement is ruled,
// and the core is never the wrong side on the built-in scenes.
TEST(ExactReferee, ValidationOfBuiltInFramesFindsTheCoreNeverWrong) {
  for (const char* name : {"cornell", "interior"}) {
    const Scene scene = load_scene(name);
    BuildParams params;
    const Bvh bvh = build_bvh(scene, params);
    const MemoryImage image(scene, bvh);
    const TraversalContext context(scene, bvh, image);
    const EmbreeScene embree(scene);
    EffectSettings settings;
    settings.width = 64;
    settings.height = 64;
    for (const Camera& camera : scene.cameras) {
      const FrameRun run = run_frame(context, camera, settings);
      ValidationRule rule;
      rule.absolute_bound = 1e-6f * scene.diagonal();
      const ValidationResult v = validate_against_embree(embree, run.rays, run.results, rule, 0, &scene);
      EXPECT_TRUE(v.refereed);
      EXPECT_EQ(v.embree_wrong + v.core_wrong + v.both_admissible, v.disagreements) << name;
      EXPECT_EQ(v.core_wrong, 0u) << name << " " << camera.name << ": "
                                  << (v.examples.empty() ? "" : v.examples.front());
      EXPECT_EQ(v.failures(), v.core_wrong);
      // The disagreement is there, and ruled against Embree.
      if (std::string(name) == "cornell" && camera.name == "view1") EXPECT_GE(v.embree_wrong, 1u);
    }
  }
}

// The referee can say "core wrong": a core that loses hits, or reports the wrong
// distance, fails validation however the ray lies.
TEST(ExactReferee, ACoreThatLosesHitsIsRuledWrong) {
  const Scene scene = load_scene("cornell");
  BuildParams params;
  const Bvh bvh = build_bvh(scene, params);
  const MemoryImage image(scene, bvh);
  const TraversalContext context(scene, bvh, image);
  const EmbreeScene embree(scene);
  EffectSettings settings;
  settings.width = 32;
  settings.height = 32;
  settings.ao_samples = 0;
  const FrameRun run = run_frame(context, scene.default_camera(), settings);
  std::vector<TraceResult> broken = run.results;
  size_t lost = 0, moved = 0;
  for (size_t i = 0; i < broken.size(); i += 7) {
    if (!broken[i].hit.hit()) continue;
    if ((i / 7) % 2 == 0) {
      broken[i].hit = HitRecord{};  // a miss where the surface is
      ++lost;
    } else if (traversal_mode_for(run.rays[i].type) == TraversalMode::ClosestHit) {  // any-hit: t is free
      broken[i].hit.t *= 1.5f;  // the right triangle at the wrong distance
      ++moved;
    }
  }
  ASSERT_GT(lost, 10u);
  ASSERT_GT(moved, 10u);
  ValidationRule rule;
  rule.absolute_bound = 1e-6f * scene.diagonal();
  const ValidationResult v = validate_against_embree(embree, run.rays, broken, rule, 0, &scene);
  EXPECT_GE(v.core_wrong, lost + moved);
  EXPECT_EQ(v.failures(), v.core_wrong);
}
