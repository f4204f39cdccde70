// Every builder on the hard inputs of issue 5. tests/builder already checks each
// builder's validity on small one-centroid / coplanar / one-point / zero-area
// scenes and equal weights == SAH on a soup; these add the sizes, the finite
// costs, non-finite and huge vertices, the 2^-i staircase, SBVH split-plane
// geometry and degenerate weights on degenerate scenes.
#include "robustness/robustness_support.h"

#include <rtsim/builder/metrics.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/validate.h>

#include <gtest/gtest.h>

#include "builder/scene_fixtures.h"

#include <cmath>
#include <cstring>

namespace rtsim {
namespace {

using namespace robust;

// The weighted-SAH core builders (sah, sbvh, osah, aobvh and any later policy);
// median and the Embree builders stand apart.
bool on_weighted_core(const std::string& builder) {
  return builder != "median" && builder.rfind("embree", 0) != 0;
}

BuildParams params_for(const std::string& builder) {
  BuildParams p;
  p.builder = builder;
  p.ao_rays = 4;  // enough to exercise the estimator, cheap on 65k triangles
  p.osah_width = p.osah_height = 64;
  return p;
}

// Builds, validates and checks reference counts: every triangle referenced
// exactly once (at least once and within the budget for split references),
// every leaf within max_leaf_size. Returns the tree.
Bvh build_checked(const Scene& scene, const BuildParams& p, BuildReport* report = nullptr) {
  const Bvh bvh = build_bvh(scene, p, report);
  const BvhValidation v = validate_bvh(bvh, scene, limits_for(p));
  EXPECT_TRUE(v.ok()) << p.builder << " on " << scene.name << ":\n" << v.summary();
  std::vector<uint32_t> refs(scene.triangle_count(), 0);
  for (const BvhNode& n : bvh.nodes) {
    EXPECT_LE(n.count, p.max_leaf_size) << p.builder << " on " << scene.name;
    if (n.is_leaf())
      for (uint32_t k = 0; k < n.count; ++k) ++refs[bvh.prim_refs[n.index + k]];
  }
  uint64_t wrong = 0;
  size_t first_wrong = 0;
  for (size_t t = 0; t < refs.size(); ++t) {
    const bool ok = limits_for(p).split_references ? refs[t] >= 1 : refs[t] == 1;
    if (!ok && wrong++ == 0) first_wrong = t;
  }
  EXPECT_EQ(wrong, 0u) << p.builder << " on " << scene.name << ": first triangle with a wrong "
                       << "reference count: " << first_wrong;
  return bvh;
}

Scene identical_triangles(uint32_t n) {
  Scene s = bare_scene("identical-" + std::to_string(n));
  for (uint32_t i = 0; i < n; ++i)
    add_triangle(s, vec3(0.1f, 0.2f, 0.0f), vec3(0.9f, 0.3f, 0.1f), vec3(0.4f, 0.8f, -0.1f));
  return s;
}

// Property: N identical triangles (1, 256, 65,536): every builder terminates,
// every leaf holds <= max_leaf_size, each triangle is referenced once.
TEST(RobustBuilders, IdenticalTrianglesTerminateWithinLeafLimitsAndReferenceEachOnce) {
  for (uint32_t n : {1u, 256u, 65536u}) {
    const Scene scene = identical_triangles(n);
    for (const std::string& builder : builder_names()) {
      BuildParams p = params_for(builder);
      // AO estimation on 65,536 coincident triangles is quadratic (every AO ray
      // meets every duplicate in Embree: 186 s measured with K = 4), so the large
      // case supplies occlusion values; 1 and 256 run the estimator.
      if (builder.rfind("ao", 0) == 0 && n > 256) p.occlusion_values.assign(n, 0.5f);  // aobvh, aosbvh
      build_checked(scene, p);
    }
  }
}

// All triangles share one box centre, with 64 different box shapes.
Scene one_centroid(uint32_t n) {
  Scene s = bare_scene("one-centroid");
  for (uint32_t i = 0; i < n; ++i) {
    const vec3 d(float(1 + i % 8) / 16.0f, float(1 + (i / 8) % 8) / 16.0f, 0.25f);  // dyadic: exact centres
    add_triangle(s, vec3(0.5f) + d, vec3(0.5f) - d, vec3(0.5f));
  }
  return s;
}

// Property: one centroid for 4096 triangles of different sizes: leaves within
// the limit for every builder; the weighted-SAH core falls back to median splits.
TEST(RobustBuilders, OneCentroidWithDifferentSizesFallsBackToMedianSplits) {
  const Scene scene = one_centroid(4096);
  for (const std::string& builder : builder_names()) {
    BuildReport report;
    build_checked(scene, params_for(builder), &report);
    if (on_weighted_core(builder)) EXPECT_GT(report.median_splits, 0u) << builder;
  }
}

// Property: coplanar triangles (flat root box) and all vertices at one point:
// every builder's tree is valid and its SAH, weighted and EPO costs are finite
// and >= 0.
TEST(RobustBuilders, FlatAndPointScenesGiveValidTreesWithFiniteCosts) {
  Scene flat = bare_scene("coplanar");
  for (uint32_t i = 0; i < 2000; ++i) {
    KeyedRng rng(3, {i});
    const vec3 c(rng.next_float(), rng.next_float(), 0.0f);
    add_triangle(flat, c, c + vec3(0.02f, 0, 0), c + vec3(0, 0.02f, 0));
  }
  Scene point = bare_scene("one-point");
  for (uint32_t i = 0; i < 300; ++i) add_triangle(point, vec3(0.25f), vec3(0.25f), vec3(0.25f));
  for (const Scene* scene : {&flat, &point})
    for (const std::string& builder : builder_names()) {
      const BuildParams p = params_for(builder);
      BuildReport report;
      const Bvh bvh = build_checked(*scene, p, &report);
      const BvhMetrics m = compute_metrics(bvh, *scene, p, report, true);
      for (double cost : {m.sah_cost, m.weighted_cost, m.epo}) {
        EXPECT_TRUE(std::isfinite(cost)) << builder << " on " << scene->name;
        EXPECT_GE(cost, 0.0) << builder << " on " << scene->name;
      }
    }
}

// Property: a mesh with NaN, +-Inf, 1e30 and 1e17 vertices follows the
// documented load policy (scene.h: triangles with a non-finite vertex are
// dropped and counted, so are those beyond +-1e18; 1e17 is kept), every builder
// then gives a valid tree, and rays at the ordinary triangles hit exactly what
// the double reference hits.
TEST(RobustBuilders, NonFiniteAndHugeVerticesFollowThePolicyAndTheRestStillHits) {
  Scene scene = bare_scene("poisoned");
  const float nan = kNaN, inf = kInf;
  uint32_t ordinary = 0;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) {
      const vec3 p(float(i) * 0.1f, float(j) * 0.1f, 0.0f);
      add_triangle(scene, p, p + vec3(0.1f, 0, 0), p + vec3(0, 0.1f, 0));
      ++ordinary;
    }
  const uint32_t good_triangles = ordinary;
  const vec3 poison[] = {vec3(nan, 0, 0), vec3(0, inf, 0), vec3(0, 0, -inf), vec3(nan)};
  for (const vec3& bad : poison) {
    add_triangle(scene, bad, vec3(0.5f, 0.5f, 1), vec3(0.6f, 0.5f, 1));
    add_triangle(scene, vec3(0.5f, 0.5f, 1), bad, vec3(0.6f, 0.5f, 1));
  }
  // Huge but finite, beyond the policy's range: dropped (areas overflow float, and
  // Embree aborts on them - found by this suite).
  add_triangle(scene, vec3(1e30f, 0, 5), vec3(1e30f, 1e30f, 5), vec3(-1e30f, 0, 5));
  add_triangle(scene, vec3(0, -1e30f, -5), vec3(1e30f, 1e30f, -5), vec3(-1e30f, 1e30f, -5));
  // Huge within the range: kept, one above and one below the rays' origins.
  add_triangle(scene, vec3(1e17f, 0, 5), vec3(1e17f, 1e17f, 5), vec3(-1e17f, 0, 5));
  add_triangle(scene, vec3(0, -1e17f, -5), vec3(1e17f, 1e17f, -5), vec3(-1e17f, 1e17f, -5));
  validate_scene(scene);
  EXPECT_EQ(scene.validation.dropped_non_finite, 8u);
  EXPECT_EQ(scene.validation.dropped_out_of_range, 2u);
  EXPECT_EQ(scene.triangle_count(), good_triangles + 2);

  std::vector<Ray> rays;
  for (uint32_t k = 0; k < 2000; ++k) {
    KeyedRng rng(17, {k});
    // A point inside an ordinary triangle (lower-left half of a 0.1 cell).
    float b1 = rng.next_float(), b2 = rng.next_float();
    if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
    const vec3 cell(float(rng.next_u64() % 20) * 0.1f, float(rng.next_u64() % 20) * 0.1f, 0.0f);
    const vec3 target = cell + vec3(0.1f * b1, 0.1f * b2, 0.0f);
    const vec3 o = target + vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, 1.0f) * 2.0f;
    rays.push_back(make_ray(o, target - o));  // starts between the two huge triangles
  }
  for (const std::string& builder : builder_names()) {
    const BuildParams p = params_for(builder);
    const Bvh bvh = build_checked(scene, p);
    const MemoryImage image(scene, bvh);
    const TraversalContext context(scene, bvh, image);
    std::vector<TraceResult> results;
    trace_rays(context, rays, results);
    for (size_t k = 0; k < rays.size(); ++k) {
      const ReferenceClosest ref = reference_closest(scene, rays[k].origin, rays[k].direction);
      ASSERT_EQ(results[k].hit.hit(), ref.hit)
          << builder << " ray " << k << " ref prim " << ref.prim << " t " << ref.t << " core prim "
          << results[k].hit.prim;
      // Two ordinary triangles meet where a ray lands: either is right then.
      if (results[k].hit.prim != ref.prim)
        EXPECT_NEAR(double(results[k].hit.t), ref.t, 1e-6 * ref.t) << builder << " ray " << k;
    }
  }
}

// Triangles in the planes x = 2^-i, i = 0..200 (below 2^-149 the coordinate
// underflows to 0: those are duplicates of one plane).
Scene staircase() {
  Scene s = bare_scene("staircase");
  for (int i = 0; i <= 200; ++i) {
    const float x = std::ldexp(1.0f, -i);
    add_triangle(s, vec3(x, 0, 0), vec3(x, 1, 0), vec3(x, 0, 1));
  }
  return s;
}

// Property: primitives at x = 2^-i, i = 0..200: every builder keeps the depth
// within max_depth (validate), a ray starting between planes k and k-1 finds
// plane k (the double reference), and no ray's stack overflows; with a 4-entry
// stack overflows are counted (never silent) and spilling keeps every hit.
TEST(RobustBuilders, PowersOfTwoStaircaseKeepsTheDepthCapAndTheStackHonest) {
  const Scene scene = staircase();
  std::vector<Ray> rays;
  for (int k = 0; k <= 140; ++k) {  // normal floats: 1.5 x 2^-k is exact
    const float x = 1.5f * std::ldexp(1.0f, -k);
    rays.push_back(make_ray(vec3(x, 0.25f, 0.25f), vec3(-1, 0, 0)));
    rays.push_back(make_ray(vec3(x, 0.25f, 0.25f), vec3(1, 0, 0)));
  }
  for (const std::string& builder : builder_names()) {
    BuildParams p = params_for(builder);
    p.max_depth = 32;
    const Bvh bvh = build_checked(scene, p);
    const MemoryImage image(scene, bvh);
    TraversalContext context(scene, bvh, image);
    TraversalConfig short_stack;
    short_stack.stack_limit = 4;
    const TraversalContext spilling(scene, bvh, image, short_stack);
    std::vector<TraceResult> results, spilled;
    trace_rays(context, rays, results);
    trace_rays(spilling, rays, spilled);
    for (size_t r = 0; r < rays.size(); ++r) {
      const ReferenceClosest ref = reference_closest(scene, rays[r].origin, rays[r].direction);
      ASSERT_EQ(ref.hit, r != 1);  // only the +x ray from x = 1.5 has nothing ahead
      ASSERT_EQ(results[r].hit.hit(), ref.hit) << builder << " ray " << r;
      if (ref.hit) EXPECT_EQ(double(results[r].hit.t), ref.t) << builder << " ray " << r;  // exact: powers of two
      EXPECT_EQ(results[r].counters.stack_overflows, 0u) << builder;
      EXPECT_LE(results[r].counters.max_stack_depth, context.config().stack_limit);
      EXPECT_EQ(spilled[r].hit.t, results[r].hit.t) << builder << " ray " << r;
      // Never unnoticed: a stack that grew past its 4 entries counted the overflow.
      if (spilled[r].counters.max_stack_depth > 4u || spilled[r].counters.stack_refills > 0)
        EXPECT_GT(spilled[r].counters.stack_overflows, 0u) << builder << " ray " << r;
    }
  }
}

// ------------------------------------------------------------ SBVH split planes

// Clips triangle abc to a box in double (Sutherland-Hodgman); true when some
// part of it (a point at least) lies in the box, faces inclusive.
bool triangle_touches_box(const vec3& a, const vec3& b, const vec3& c, const Aabb& box) {
  std::vector<dvec3> poly{dvec3(a), dvec3(b), dvec3(c)};
  for (int axis = 0; axis < 3 && !poly.empty(); ++axis)
    for (int side = 0; side < 2 && !poly.empty(); ++side) {
      const double plane = side ? box.hi[axis] : box.lo[axis];
      auto inside = [&](const dvec3& p) { return side ? p[axis] <= plane : p[axis] >= plane; };
      std::vector<dvec3> out;
      for (size_t i = 0; i < poly.size(); ++i) {
        const dvec3 &p = poly[i], &q = poly[(i + 1) % poly.size()];
        if (inside(p)) out.push_back(p);
        if (inside(p) != inside(q)) {
          const double s = (plane - p[axis]) / (q[axis] - p[axis]);
          dvec3 x = p + s * (q - p);
          x[axis] = plane;
          out.push_back(x);
        }
      }
      poly = std::move(out);
    }
  return !poly.empty();
}

// Property: SBVH (and Embree's SBVH) on triangles lying in or touching the
// planes a spatial split would use: no empty node box, every leaf reference's
// triangle really intersects its leaf box (the clipped part is not empty),
// references within the budget, and every triangle reachable: rays at random
// points of every triangle give the same hit as Embree (the oracle).
TEST(RobustBuilders, SbvhOnSplitPlaneGeometryKeepsEveryReferenceHonest) {
  Scene scene = bare_scene("split-planes");
  // Long slivers crossing the whole box (spatial splits pay off) ...
  for (uint32_t i = 0; i < 600; ++i) {
    KeyedRng rng(5, {i});
    const vec3 a(rng.next_float(), rng.next_float(), rng.next_float());
    add_triangle(scene, a, vec3(1.0f - a.x, rng.next_float(), rng.next_float()), a + vec3(0, 0.004f, 0));
  }
  // ... triangles lying in the dyadic planes x = k/32 (bin boundaries of a unit box) ...
  for (int k = 0; k <= 32; k += 4)
    for (int j = 0; j < 8; ++j) {
      const float x = float(k) / 32.0f, y = float(j) / 8.0f;
      add_triangle(scene, vec3(x, y, 0.1f), vec3(x, y + 0.125f, 0.1f), vec3(x, y, 0.9f));
    }
  // ... and triangles touching those planes with one vertex or one edge.
  for (int k = 4; k < 32; k += 4) {
    const float x = float(k) / 32.0f;
    add_triangle(scene, vec3(x, 0.3f, 0.3f), vec3(x + 0.1f, 0.35f, 0.3f), vec3(x + 0.05f, 0.3f, 0.4f));
    add_triangle(scene, vec3(x, 0.6f, 0.6f), vec3(x, 0.7f, 0.6f), vec3(x - 0.1f, 0.65f, 0.7f));
  }
  const EmbreeScene embree(scene);
  std::vector<Ray> rays;
  for (uint32_t t = 0; t < scene.triangle_count(); ++t)
    for (uint32_t j = 0; j < 6; ++j) {
      KeyedRng rng(6, {t, j});
      float b1 = rng.next_float(), b2 = rng.next_float();
      if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
      const vec3 a = scene.vertex(t, 0), b = scene.vertex(t, 1), c = scene.vertex(t, 2);
      const vec3 target = a + b1 * (b - a) + b2 * (c - a);
      const vec3 d(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f);
      rays.push_back(make_ray(target - 2.0f * d, d));
    }
  for (const std::string builder : {"sbvh", "embree-sbvh"}) {
    BuildParams p = params_for(builder);
    p.sbvh_alpha = 0.0f;  // split whenever it is cheaper: the most splits
    BuildReport report;
    const Bvh bvh = build_checked(scene, p, &report);
    if (builder == "sbvh") EXPECT_GT(report.spatial_splits, 0u);
    EXPECT_LE(double(bvh.prim_refs.size()), limits_for(p).reference_budget * double(scene.triangle_count()));
    for (size_t i = 0; i < bvh.nodes.size(); ++i) {
      const BvhNode& n = bvh.nodes[i];
      ASSERT_FALSE(n.bounds.empty()) << builder << " node " << i;
      if (!n.is_leaf()) continue;
      for (uint32_t k = 0; k < n.count; ++k) {
        const uint32_t t = bvh.prim_refs[n.index + k];
        EXPECT_TRUE(triangle_touches_box(scene.vertex(t, 0), scene.vertex(t, 1), scene.vertex(t, 2), n.bounds))
            << builder << ": leaf " << i << " references triangle " << t << " which lies outside its box";
      }
    }
    const MemoryImage image(scene, bvh);
    const TraversalContext context(scene, bvh, image);
    std::vector<TraceResult> results;
    trace_rays(context, rays, results);
    for (size_t r = 0; r < rays.size(); ++r) {
      const EmbreeHit e = embree.intersect(rays[r].origin, rays[r].direction, 0.0f, kInf);
      ASSERT_EQ(results[r].hit.hit(), e.hit) << builder << " ray " << r;
      if (results[r].hit.prim != e.prim)
        EXPECT_NEAR(results[r].hit.t, e.t, 1e-5f * e.t) << builder << " ray " << r;
    }
  }
}

// ------------------------------------------------------------ degenerate weights

// Property: AO-BVH with occlusion values all 0, all 1, all NaN, and a NaN/Inf/
// negative mix; OSAH with visibility all 0 / all 1 and osah_w 0 and 1: they
// terminate with leaves within the limit on the degenerate scenes (identical
// triangles, one centroid, the staircase, a flat scene); all-equal weights give
// exactly the SAH tree, and no visible triangle OSAH's plain policy. osah_w = NaN is refused as an InputError (check_params).
TEST(RobustBuilders, DegenerateWeightsOnDegenerateScenesTerminateAndEqualWeightsGiveSah) {
  Scene flat = bare_scene("flat");
  for (uint32_t i = 0; i < 500; ++i) {
    KeyedRng rng(8, {i});
    const vec3 c(rng.next_float(), 0.5f, rng.next_float());
    add_triangle(flat, c, c + vec3(0.03f, 0, 0), c + vec3(0, 0, 0.03f));
  }
  const Scene scenes[] = {identical_triangles(300), one_centroid(256), staircase(), flat};
  for (const Scene& scene : scenes) {
    const size_t n = scene.triangle_count();
    BuildParams sah_params = params_for("sah");
    const Bvh sah = build_bvh(scene, sah_params);
    for (float value : {0.0f, 1.0f, kNaN}) {
      BuildParams p = params_for("aobvh");
      p.ao_weight_floor = 0.0f;
      p.occlusion_values.assign(n, value);
      BuildReport report;
      const Bvh tree = build_checked(scene, p, &report);
      EXPECT_TRUE(test::same_tree(tree, sah)) << scene.name << " occlusion " << value;
      EXPECT_EQ(report.sanitised_values, std::isnan(value) ? n : 0u);
    }
    BuildParams mixed = params_for("aobvh");
    mixed.ao_weight_floor = 0.0f;
    mixed.occlusion_values.resize(n);
    uint64_t bad = 0;
    for (size_t i = 0; i < n; ++i) {
      const float choices[] = {0.0f, 1.0f, kNaN, kInf, -1.0f, 0.5f};
      mixed.occlusion_values[i] = choices[i % 6];
      bad += (i % 6 == 2 || i % 6 == 3 || i % 6 == 4) ? 1 : 0;
    }
    BuildReport mixed_report;
    build_checked(scene, mixed, &mixed_report);
    EXPECT_EQ(mixed_report.sanitised_values, bad) << scene.name;
    // OSAH's rules act only on mixed nodes: with none visible its tree is SBVH's
    // object splits (spatial splits from past the depth limit: none).
    BuildParams object_only = params_for("sbvh");
    object_only.treelet_passes = 0;
    object_only.sbvh_min_depth = object_only.max_depth;
    const Bvh plain = build_checked(scene, object_only);
    for (uint8_t visible : {uint8_t(0), uint8_t(1)})
      for (float w : {0.0f, 1.0f}) {
        BuildParams p = params_for("osah");
        p.osah_w = w;
        p.visibility.assign(n, visible);
        const Bvh tree = build_checked(scene, p);
        if (visible == 0) EXPECT_TRUE(test::same_tree(tree, plain)) << scene.name << " w " << w;
      }
    BuildParams nan_w = params_for("osah");
    nan_w.osah_w = kNaN;
    EXPECT_THROW(build_bvh(scene, nan_w), InputError);
  }
}

}  // namespace
}  // namespace rtsim
