// Functional core: robust box test, watertight triangle test, traversal state
// machine and its counters.
#include "model/core_test_support.h"

#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/model/core/traversal.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/random.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <limits>

using namespace rtsim;

namespace {
const float kInf = std::numeric_limits<float>::infinity();
const float kNaN = std::numeric_limits<float>::quiet_NaN();

bool box_hit(vec3 o, vec3 d, const Aabb& box, float tmin = 0.0f, float tmax = kInf) {
  float t;
  return intersect_box(RayBoxPrecompute(o, d), box, tmin, tmax, &t);
}
}  // namespace

TEST(CoreBox, ZeroDirectionComponentsInsideAndOutsideTheSlab) {
  const Aabb box{vec3(0.0f), vec3(1.0f)};
  EXPECT_TRUE(box_hit({0.5f, 0.5f, -1.0f}, {0.0f, 0.0f, 1.0f}, box));
  EXPECT_TRUE(box_hit({0.5f, 0.5f, -1.0f}, {-0.0f, -0.0f, 1.0f}, box));
  EXPECT_FALSE(box_hit({1.5f, 0.5f, -1.0f}, {0.0f, 0.0f, 1.0f}, box));
  EXPECT_FALSE(box_hit({-0.5f, 0.5f, -1.0f}, {-0.0f, 0.0f, 1.0f}, box));
}

TEST(CoreBox, OriginOnAFacePlaneWithParallelDirectionHits) {
  const Aabb box{vec3(0.0f), vec3(1.0f)};
  // Origin x exactly on the lo / hi face, ray parallel to that face: 0 * inf.
  for (float x : {0.0f, 1.0f})
    for (float dx : {0.0f, -0.0f}) {
      EXPECT_TRUE(box_hit({x, 0.5f, -1.0f}, {dx, 0.0f, 1.0f}, box)) << x << " " << dx;
      EXPECT_TRUE(box_hit({x, 0.5f, 2.0f}, {dx, 0.0f, -1.0f}, box)) << x << " " << dx;
    }
  // A flat box (a wall) with the ray running inside its plane.
  const Aabb wall{vec3(0.0f, 0.0f, 3.0f), vec3(1.0f, 1.0f, 3.0f)};
  EXPECT_TRUE(box_hit({0.5f, -1.0f, 3.0f}, {0.0f, 1.0f, 0.0f}, wall));
  // Origin on a face, pointing away / into the box.
  EXPECT_TRUE(box_hit({0.0f, 0.5f, 0.5f}, {1.0f, 0.0f, 0.0f}, box));
  EXPECT_TRUE(box_hit({0.0f, 0.5f, 0.5f}, {-1.0f, 0.0f, 0.0f}, box));  // t = 0 at the face
  EXPECT_FALSE(box_hit({0.0f, 0.5f, 0.5f}, {-1.0f, 0.0f, 0.0f}, box, 1e-3f));
}

TEST(CoreBox, TightBoxAroundAFarAwayTriangleIsNeverMissed) {
  // Rays that hit a triangle must hit its bounding box, however far out (Ize 2013).
  const vec3 c(148376.0f, 1234.0f, -223423.0f);
  uint64_t misses = 0;
  for (uint32_t i = 0; i < 20000; ++i) {
    KeyedRng rng(7, {i});
    const vec3 a = c + vec3(rng.next_float(), rng.next_float(), rng.next_float()) * 3.0f;
    const vec3 b = a + vec3(rng.next_float(), rng.next_float(), 0.0f);
    const vec3 d = a + vec3(0.0f, rng.next_float(), rng.next_float());
    const vec3 o = c + vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f) * 400.0f;
    const float w1 = rng.next_float(), w2 = rng.next_float() * (1.0f - w1);
    const vec3 target = a + w1 * (b - a) + w2 * (d - a);
    TriangleHit th;
    if (!intersect_triangle(RayTrianglePrecompute(o, target - o), a, b, d, 0.0f, kInf, &th)) continue;
    if (!box_hit(o, target - o, Aabb::of_triangle(a, b, d))) ++misses;
  }
  EXPECT_EQ(misses, 0u);
}

// The traversal tests a record's boxes four at a time, a binary record's two at
// a time (intersect_box_lanes).
// Property: its hit and entry distance are the scalar test's, bit for bit, for
// random boxes and rays and for the awkward ones: zero and negative-zero
// direction components, origins on face planes (0 * inf), flat and empty
// boxes, infinite tmax and closest-hit limits inside the box.
TEST(CoreBox, LaneSlabTestsGiveTheScalarAnswersBitForBit) {
  const float specials[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f, 2.0f, kInf, -kInf, 1e-30f, 3e7f};
  uint64_t checked = 0, hits = 0;
  for (uint32_t i = 0; i < 200000; ++i) {
    KeyedRng rng(2024, {i});
    const auto coord = [&](bool special) {
      return special ? specials[uint32_t(rng.next_u64()) % 10] : (rng.next_float() - 0.5f) * 8.0f;
    };
    const bool awkward = i % 4 == 0;
    vec3 o, d;
    Aabb boxes[4];
    for (int a = 0; a < 3; ++a) {
      d[a] = coord(awkward && uint32_t(rng.next_u64()) % 3 == 0);
      for (Aabb& b : boxes) {
        float lo = coord(false), hi = coord(false);
        if (lo > hi && uint32_t(rng.next_u64()) % 8 != 0) std::swap(lo, hi);  // some empty boxes
        if (awkward && uint32_t(rng.next_u64()) % 4 == 0) hi = lo;              // flat
        b.lo[a] = lo, b.hi[a] = hi;
      }
      // Origins on a face plane of either box now and then.
      o[a] = awkward && uint32_t(rng.next_u64()) % 3 == 0 ? (uint32_t(rng.next_u64()) % 2 ? boxes[i % 4].lo[a] : boxes[(i / 4) % 4].hi[a])
                                                : coord(false);
    }
    if (d == vec3(0.0f)) continue;
    const float tmin = uint32_t(rng.next_u64()) % 2 ? 0.0f : rng.next_float();
    const float tmax = uint32_t(rng.next_u64()) % 2 ? kInf : rng.next_float() * 6.0f;
    const RayBoxPrecompute pre(o, d);
    BoxQuadLanes quad{};
    BoxPairLanes pair{};  // a binary record's layout: the first two boxes
    for (int k = 0; k < 4; ++k) quad.set(k, boxes[k]);
    for (int k = 0; k < 2; ++k) pair.set(k, boxes[k]);
    float in_quad[4], in_pair[4];
    const uint32_t quad_mask = intersect_box_lanes(RayBoxLanes(pre), quad, tmin, tmax, in_quad);
    const uint32_t pair_mask = intersect_box_lanes(RayBoxLanes(pre), pair, tmin, tmax, in_pair);
    for (int k = 0; k < 4; ++k) {
      float scalar = 0.0f;
      const bool hit = intersect_box(pre, boxes[k], tmin, tmax, &scalar);
      ASSERT_EQ(hit, ((quad_mask >> k) & 1u) != 0) << "case " << i << " box " << k;
      uint32_t a, b;
      std::memcpy(&a, &scalar, 4);
      std::memcpy(&b, &in_quad[k], 4);
      ASSERT_EQ(a, b) << "case " << i << " box " << k << ": " << scalar << " vs " << in_quad[k];
      if (k < 2) {
        ASSERT_EQ(hit, ((pair_mask >> k) & 1u) != 0) << "case " << i << " pair box " << k;
        std::memcpy(&b, &in_pair[k], 4);
        ASSERT_EQ(a, b) << "case " << i << " pair box " << k << ": " << scalar << " vs " << in_pair[k];
      }
      hits += hit;
      ++checked;
    }
  }
  EXPECT_GT(checked, 780000u);
  EXPECT_GT(hits, checked / 20);  // both answers occur often
  EXPECT_LT(hits, checked - checked / 20);
}

namespace {

struct QuadCheckCounts {
  uint64_t float_lanes = 0, exact_lanes = 0, hits = 0;
};

// Random quads of triangles and rays (see FourLaneTestGivesTheScalarVerdictsBitForBit),
// every coordinate times `scale`, each lane checked against the scalar test.
void check_quads_against_scalar(uint64_t seed, uint32_t cases, float scale, QuadCheckCounts* counts) {
  for (uint32_t i = 0; i < cases; ++i) {
    KeyedRng rng(seed, {i});
    const auto point = [&] {
      return vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f) * 4.0f * scale;
    };
    float vertices[36];
    vec3 tri[4][3];
    for (int k = 0; k < 4; ++k) {
      for (int j = 0; j < 3; ++j) tri[k][j] = point();
      const uint32_t kind = uint32_t(rng.next_u64()) % 8;
      if (kind == 0) tri[k][2] = tri[k][1];                                // degenerate
      if (kind == 1 && k > 0) tri[k][0] = tri[k - 1][1], tri[k][1] = tri[k - 1][0];  // a shared edge
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a) vertices[9 * k + 3 * j + a] = tri[k][j][a];
    }
    vec3 o = point() * 2.0f, target;
    const uint32_t aim = uint32_t(rng.next_u64()) % 6;
    const vec3* t0 = tri[i % 4];
    if (aim == 0) target = t0[0];                                   // through a vertex
    else if (aim == 1) target = 0.5f * (t0[0] + t0[1]);             // through an edge
    else if (aim == 2) o = t0[0] + 3.0f * (t0[1] - t0[0]), target = t0[1];  // along an edge, in the plane
    else if (aim == 3) target = (t0[0] + t0[1] + t0[2]) / 3.0f;    // the middle
    else target = point();
    vec3 d = target - o;
    if (i % 13 == 0) d[i % 3] = 0.0f;  // zero components
    if (d == vec3(0.0f)) continue;
    const float tmin = uint32_t(rng.next_u64()) % 2 ? 0.0f : rng.next_float() * 0.5f;
    const float tmax = uint32_t(rng.next_u64()) % 2 ? kInf : rng.next_float() * 2.0f;
    const RayTrianglePrecompute pre(o, d);
    const TriangleQuadVerdict lanes = intersect_triangle_quad(RayTriangleLanes(pre), vertices, tmin, tmax);
    for (int k = 0; k < 4; ++k) {
      TriangleHit th{};
      uint32_t steps = 0;
      const bool hit = intersect_triangle(pre, tri[k][0], tri[k][1], tri[k][2], tmin, tmax, &th, &steps);
      const bool exact = (lanes.exact >> k) & 1u;
      ASSERT_EQ(exact, steps > 0) << "scale " << scale << " case " << i << " lane " << k;
      if (exact) {
        ASSERT_FALSE((lanes.hit >> k) & 1u) << "scale " << scale << " case " << i << " lane " << k;
        ++counts->exact_lanes;
        continue;
      }
      ++counts->float_lanes;
      ASSERT_EQ(hit, ((lanes.hit >> k) & 1u) != 0) << "scale " << scale << " case " << i << " lane " << k;
      if (!hit) continue;
      ++counts->hits;
      const float mine[3] = {lanes.t[k], lanes.u[k], lanes.v[k]}, theirs[3] = {th.t, th.u, th.v};
      ASSERT_EQ(std::memcmp(mine, theirs, sizeof mine), 0) << "scale " << scale << " case " << i << " lane " << k;
    }
  }
}

}  // namespace

// The four-lane triangle test decides in float exactly the lanes the scalar test
// decides in float, with its verdicts bit for bit, and flags the others (those
// where the scalar test takes a step in double) for the scalar test. The cases
// mix random triangles with rays through vertices, along edges, in the plane and
// parallel to it, and degenerate triangles.
TEST(CoreTriangle, FourLaneTestGivesTheScalarVerdictsBitForBit) {
  QuadCheckCounts counts;
  check_quads_against_scalar(2025, 100000, 1.0f, &counts);
  EXPECT_GT(counts.hits, counts.float_lanes / 20);   // both verdicts occur often
  EXPECT_GT(counts.exact_lanes, 5000u) << counts.float_lanes;  // and so do the lanes left to the scalar test
  EXPECT_GT(counts.float_lanes, 250000u);  // of 400,000 lanes, less the skipped cases
}

// The same at scales where the error bounds' products fall below float's normal
// range or beyond its largest value: the lanes must still flag exactly the
// scalar test's steps in double, and agree bit for bit elsewhere. Near 1e-19 the
// bounds' products are subnormal; near 1e19 the bounds' sums overflow, and at
// 3e19 nearly every lane's do. At 1e-36 the edge values themselves underflow, so
// every lane is left to the scalar test.
TEST(CoreTriangle, FourLaneTestKeepsTheScalarVerdictsAtExtremeScales) {
  struct Scale {
    float scale;
    bool both_kinds;  // float and scalar lanes both occur, so both paths are checked
  };
  for (const Scale& s : {Scale{1e-36f, false}, Scale{3e-20f, true}, Scale{1e-19f, true}, Scale{1e-12f, true},
                         Scale{1e12f, true}, Scale{1e18f, true}, Scale{1e19f, true}, Scale{3e19f, false}}) {
    QuadCheckCounts counts;
    check_quads_against_scalar(2026, 20000, s.scale, &counts);
    if (HasFatalFailure()) return;
    EXPECT_GT(counts.exact_lanes, 100u) << "scale " << s.scale;
    if (s.both_kinds) EXPECT_GT(counts.float_lanes, 100u) << "scale " << s.scale;
  }
}

// The watertight frame: kz is an axis of largest |d| (ties go to the later axis),
// (kx, ky, kz) is a permutation, an even one (the winding kept) exactly when the ray
// runs toward +kz, and the shear is the direction's own ratios. Every sign and
// every order of the three magnitudes, with ties and zeros.
TEST(CoreTriangle, SetUpPicksTheDominantAxisAndKeepsTheWinding) {
  const float magnitudes[] = {0.0f, 0.5f, 1.0f, 2.0f};
  int cases = 0;
  for (float mx : magnitudes)
    for (float my : magnitudes)
      for (float mz : magnitudes)
        for (int signs = 0; signs < 8; ++signs) {
          if (mx == 0.0f && my == 0.0f && mz == 0.0f) continue;
          const vec3 d((signs & 1) ? -mx : mx, (signs & 2) ? -my : my, (signs & 4) ? -mz : mz);
          const RayTrianglePrecompute r(vec3(0.0f), d);
          const float m[3] = {mx, my, mz}, dv[3] = {d.x, d.y, d.z};
          SCOPED_TRACE("d = (" + std::to_string(d.x) + ", " + std::to_string(d.y) + ", " + std::to_string(d.z) + ")");
          ASSERT_TRUE(r.kz >= 0 && r.kz < 3 && r.kx >= 0 && r.kx < 3 && r.ky >= 0 && r.ky < 3);
          EXPECT_EQ(r.kx + r.ky + r.kz, 3);
          EXPECT_NE(r.kx, r.ky);
          for (int a = 0; a < 3; ++a) {
            EXPECT_GE(m[r.kz], m[a]);
            if (a > r.kz) EXPECT_GT(m[r.kz], m[a]) << "a tie goes to the later axis";
          }
          const bool even = r.kx == (r.kz + 1) % 3;  // (kz+1, kz+2, kz) is a rotation of (0, 1, 2)
          EXPECT_EQ(even, !(dv[r.kz] < 0.0f));
          EXPECT_EQ(r.shear_x, dv[r.kx] / dv[r.kz]);
          EXPECT_EQ(r.shear_y, dv[r.ky] / dv[r.kz]);
          EXPECT_EQ(r.shear_z, 1.0f / dv[r.kz]);
          ++cases;
        }
  EXPECT_EQ(cases, 63 * 8);
}

TEST(CoreTriangle, FanSharedVertexAndEdgesHitAtLeastOnce) {
  // A fan of triangles around a centre vertex, in the plane z = 0 and tilted.
  for (int tilt = 0; tilt < 2; ++tilt) {
    const vec3 centre(tilt ? 3.25f : 0.0f, tilt ? -1.5f : 0.0f, tilt ? 7.0f : 0.0f);
    const int n = 12;
    std::vector<vec3> rim;
    for (int k = 0; k < n; ++k) {
      const float a = 6.2831853f * float(k) / float(n);
      rim.push_back(centre + vec3(std::cos(a), std::sin(a), tilt ? 0.37f * std::cos(3.0f * a) : 0.0f));
    }
    std::vector<vec3> targets{centre};
    for (int k = 0; k < n; ++k) targets.push_back(centre + 0.5f * (rim[k] - centre));
    for (int k = 0; k < n; ++k) targets.push_back(centre + 0.25f * (rim[k] - centre));
    for (const vec3& target : targets) {
      for (uint32_t j = 0; j < 64; ++j) {
        KeyedRng rng(3, {j});
        vec3 o = target + vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, 1.0f) * 4.0f;
        if (j == 0) o = target + vec3(0.0f, 0.0f, 2.0f);  // axis-aligned: edge functions exactly 0
        if (j == 1) o = target - vec3(0.0f, 0.0f, 2.0f);  // from below
        const RayTrianglePrecompute pre(o, target - o);
        int hits = 0;
        for (int k = 0; k < n; ++k) {
          TriangleHit th;
          hits += intersect_triangle(pre, centre, rim[k], rim[(k + 1) % n], 0.0f, kInf, &th) ? 1 : 0;
        }
        EXPECT_GE(hits, 1) << "tilt " << tilt << " target " << target.x << "," << target.y << " ray " << j;
      }
    }
  }
}

TEST(CoreTriangle, DegenerateAndBehindAndNonFiniteNeverHit) {
  TriangleHit th;
  const vec3 o(0.2f, 0.2f, 1.0f), d(0.0f, 0.0f, -1.0f);
  EXPECT_TRUE(intersect_triangle(RayTrianglePrecompute(o, d), vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0), 0.0f, kInf, &th));
  EXPECT_FLOAT_EQ(th.t, 1.0f);
  EXPECT_FLOAT_EQ(th.u, 0.2f);
  EXPECT_FLOAT_EQ(th.v, 0.2f);
  EXPECT_FALSE(intersect_triangle(RayTrianglePrecompute(o, -d), vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0), 0.0f, kInf, &th));
  EXPECT_FALSE(intersect_triangle(RayTrianglePrecompute(o, d), vec3(0, 0, 0), vec3(1, 0, 0), vec3(2, 0, 0), 0.0f, kInf, &th));
  EXPECT_FALSE(intersect_triangle(RayTrianglePrecompute(o, d), vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0), 0.0f, 0.5f, &th));
}

// Property: the double-precision steps are counted where, and only where, float
// rounding could decide: none for a ray through the middle of a triangle; all
// three edge functions for a ray lying in a tilted triangle's plane (each float
// value is rounding error); at least the two edges through the vertex for a ray
// aimed exactly at a vertex.
TEST(CoreTriangle, CountsTheStepsItTakesInDouble) {
  const vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  TriangleHit th;
  uint32_t steps = 0;
  EXPECT_TRUE(intersect_triangle(RayTrianglePrecompute(vec3(0.3f, 0.3f, 1), vec3(0, 0, -1)), a, b, c,
                                 0.0f, kInf, &th, &steps));
  EXPECT_EQ(steps, 0u);
  const vec3 ta(1, 0, 0), tb(0, 1, 0), tc(0, 0, 1);  // the plane x + y + z = 1
  steps = 0;
  EXPECT_FALSE(intersect_triangle(RayTrianglePrecompute(vec3(-1, 0.5f, 1.5f), vec3(1, -0.125f, -0.875f)),
                                  ta, tb, tc, 0.0f, kInf, &th, &steps));
  EXPECT_EQ(steps, 3u);
  steps = 0;
  EXPECT_TRUE(intersect_triangle(RayTrianglePrecompute(vec3(1, 0, 2), vec3(0, 0, -1)), a, b, c, 0.0f,
                                 kInf, &th, &steps));
  EXPECT_GE(steps, 2u);
}

namespace {
struct SphereScene {
  Scene scene;
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;
  vec3 centre{148376.0f, 1234.0f, -223423.0f};
  float radius = 50.0f;
  explicit SphereScene(const MemoryLayoutConfig& layout = {}) {
    test::add_material(scene, "grey", vec3(0.5f));
    MeshBuilder mb{scene};
    mb.sphere(centre, radius, 96, 192);
    bvh = test::median_bvh(scene);
    image = std::make_unique<MemoryImage>(scene, bvh, layout);
    context = std::make_unique<TraversalContext>(scene, bvh, *image);
  }
  std::vector<Ray> inside_rays(size_t count) const {
    std::vector<Ray> rays(count);
    for (size_t i = 0; i < count; ++i) {
      KeyedRng rng(11, {i});
      const vec3 jitter(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f);
      rays[i].origin = centre + jitter * radius;  // anywhere well inside
      vec3 d(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f);
      if (i % 7 == 0) d[i % 3] = 0.0f;      // zero components
      if (i % 11 == 0) d = vec3(0.0f, -0.0f, 1.0f);
      rays[i].direction = d;
      rays[i].pixel = uint32_t(i);
    }
    return rays;
  }
};
}  // namespace

TEST(CoreWatertight, ClosedSphereFarFromOriginShotFromInsideNeverMisses) {
  SphereScene s;
  ASSERT_GT(s.scene.triangle_count(), 30000u);
  const std::vector<Ray> rays = s.inside_rays(1'000'000);
  std::vector<TraceResult> results;
  trace_rays(*s.context, rays, results);
  uint64_t misses = 0;
  for (const TraceResult& r : results) misses += r.hit.hit() ? 0 : 1;
  EXPECT_EQ(misses, 0u);
}

TEST(CoreTraversal, SingleBoxLayoutFindsTheSameHits) {
  MemoryLayoutConfig single;
  single.node_format = "bvh2-32";
  SphereScene wide, narrow(single);
  const std::vector<Ray> rays = wide.inside_rays(20000);
  std::vector<TraceResult> a, b;
  trace_rays(*wide.context, rays, a);
  trace_rays(*narrow.context, rays, b);
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(a[i].hit.prim, b[i].hit.prim) << i;
    ASSERT_EQ(a[i].hit.t, b[i].hit.t) << i;
    EXPECT_EQ(b[i].counters.node_bytes, b[i].counters.node_fetches * 32u);
    EXPECT_EQ(a[i].counters.node_bytes, a[i].counters.node_fetches * 64u);
  }
}

TEST(CoreTraversal, NonFiniteRaysFinishAtOnceWithoutAHit) {
  SphereScene s;
  RayTraversal trv(*s.context);
  Ray ray;
  ray.origin = s.centre;
  for (vec3 d : {vec3(kNaN, 0, 1), vec3(kInf, 0, 1), vec3(0.0f), vec3(0, 0, 1)}) {
    ray.direction = d;
    for (float tmax : {kInf, kNaN, -1.0f}) {
      ray.tmax = tmax;
      const HitRecord& hit = trace_ray(trv, ray);
      const bool usable = d == vec3(0, 0, 1) && tmax == kInf;
      EXPECT_EQ(hit.hit(), usable);
      if (!usable) EXPECT_EQ(trv.counters().ops(), 0u);
    }
  }
  ray.direction = vec3(0, 0, 1);
  ray.tmax = kInf;
  ray.origin = vec3(kNaN, 0, 0);
  EXPECT_FALSE(trace_ray(trv, ray).hit());
}

namespace {
struct CountingSink : AccessSink {
  uint64_t fetches[kAccessKindCount] = {0, 0, 0, 0};
  uint64_t bytes[kAccessKindCount] = {0, 0, 0, 0};
  bool addresses_in_image = true;
  const MemoryImage* image = nullptr;
  void on_access(const MemoryAccess& f, RayType) override {
    ++fetches[int(f.kind)];
    bytes[int(f.kind)] += f.bytes;
    if (f.address < image->nodes_base() || f.address + f.bytes > image->end_address())
      addresses_in_image = false;
  }
};
}  // namespace

TEST(CoreTraversal, StepwiseDriveMatchesTightLoopAndCountsAgreeWithTheSink) {
  SphereScene s;
  const std::vector<Ray> rays = s.inside_rays(2000);
  RayTraversal loop(*s.context), stepper(*s.context);
  CountingSink sink;
  sink.image = s.image.get();
  uint32_t deepest = 0;
  uint64_t trv = 0, nodes = 0, prim_refs = 0, tris = 0, node_bytes = 0, tri_bytes = 0;
  for (const Ray& ray : rays) {
    const HitRecord expected = trace_ray(loop, ray, &sink);
    // A unit driving the state machine one step at a time, as the SystemC TRV/IST do.
    stepper.reset(ray);
    while (!stepper.done()) {
      if (stepper.action() == TraversalAction::TestTriangles)
        EXPECT_LT(stepper.leaf_cursor(), stepper.leaf_size());
      stepper.process();
    }
    EXPECT_EQ(stepper.hit().prim, expected.prim);
    EXPECT_EQ(stepper.hit().t, expected.t);
    const RayCounters& c = loop.counters();
    EXPECT_EQ(c.trv_ops, stepper.counters().trv_ops);
    EXPECT_EQ(c.ist_ops, stepper.counters().ist_ops);
    EXPECT_EQ(c.trv_ops, c.node_fetches);
    EXPECT_EQ(c.ist_ops, c.triangle_fetches);
    EXPECT_EQ(c.box_tests, 2 * c.trv_ops);  // wide layout: two child boxes per node
    deepest = std::max(deepest, c.max_stack_depth);
    EXPECT_EQ(c.stack_overflows, 0u);
    trv += c.trv_ops, nodes += c.node_fetches, prim_refs += c.prim_ref_fetches, tris += c.triangle_fetches;
    node_bytes += c.node_bytes, tri_bytes += c.triangle_bytes;
  }
  EXPECT_EQ(sink.fetches[int(AccessKind::Node)], nodes);
  EXPECT_EQ(sink.fetches[int(AccessKind::PrimRef)], prim_refs);
  EXPECT_EQ(sink.fetches[int(AccessKind::Triangle)], tris);
  EXPECT_EQ(sink.bytes[int(AccessKind::Node)], node_bytes);
  EXPECT_EQ(sink.bytes[int(AccessKind::Triangle)], tri_bytes);
  EXPECT_TRUE(sink.addresses_in_image);
  EXPECT_GT(deepest, 1u);
  EXPECT_GT(trv, rays.size());
}

TEST(CoreTraversal, ShortStackOverflowIsCountedAndSpillingKeepsResultsExact) {
  SphereScene deep;
  TraversalConfig shallow;
  shallow.stack_limit = 2;
  TraversalContext spill(deep.scene, deep.bvh, *deep.image, shallow);
  shallow.overflow_policy = StackOverflowPolicy::DropOldest;
  TraversalContext drop(deep.scene, deep.bvh, *deep.image, shallow);
  const std::vector<Ray> rays = deep.inside_rays(5000);
  std::vector<TraceResult> exact, spilled, dropped;
  trace_rays(*deep.context, rays, exact);
  trace_rays(spill, rays, spilled);
  trace_rays(drop, rays, dropped);
  uint64_t overflows = 0, refills = 0, dropped_misses = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    EXPECT_EQ(exact[i].hit.prim, spilled[i].hit.prim);
    EXPECT_EQ(exact[i].counters.ops(), spilled[i].counters.ops());
    overflows += spilled[i].counters.stack_overflows;
    refills += spilled[i].counters.stack_refills;
    EXPECT_EQ(dropped[i].counters.stack_overflows > 0 || dropped[i].hit.prim == exact[i].hit.prim, true);
    dropped_misses += dropped[i].hit.hit() ? 0 : 1;
  }
  EXPECT_GT(overflows, 0u);
  EXPECT_GT(refills, 0u);
  EXPECT_LE(refills, overflows);
  (void)dropped_misses;
}

TEST(CoreTraversal, BadBvhIsRefused) {
  SphereScene s;
  Bvh bad = s.bvh;
  bad.nodes[0].index = 0;  // root's children would be the root itself: a cycle
  EXPECT_THROW(MemoryImage(s.scene, bad), InputError);
  Bvh bad_ref = s.bvh;
  bad_ref.prim_refs[3] = uint32_t(s.scene.triangle_count());
  EXPECT_THROW(MemoryImage(s.scene, bad_ref), InputError);
}

namespace {
// Every step's reads, recorded with their dependency split.
struct StepLog {
  std::vector<std::vector<MemoryAccess>> reads;
  std::vector<uint32_t> independent;
  std::vector<MemoryAccess> stack;
};
StepLog drive(RayTraversal& trv, const Ray& ray) {
  StepLog log;
  trv.reset(ray);
  while (!trv.done()) {
    log.reads.push_back(trv.step_reads());
    log.independent.push_back(trv.step_independent_reads());
    trv.process();
    log.stack.insert(log.stack.end(), trv.stack_accesses().begin(), trv.stack_accesses().end());
  }
  return log;
}
}  // namespace

TEST(CoreTraversal, AStepReadsItsLeafsTrianglesTogetherBehindThePrimRefList) {
  SphereScene s;
  TraversalConfig one, four;
  one.triangles_per_step = 1;
  four.triangles_per_step = 4;
  const TraversalContext c1(s.scene, s.bvh, *s.image, one), c4(s.scene, s.bvh, *s.image, four);
  RayTraversal t1(c1), t4(c4);
  std::vector<Ray> rays = s.inside_rays(3000);
  uint64_t over_fetched = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    Ray ray = rays[i];
    ray.type = i % 2 ? RayType::Ao : RayType::Primary;  // any-hit and closest-hit
    const StepLog log = drive(t4, ray);
    for (size_t k = 0; k < log.reads.size(); ++k) {
      const auto& r = log.reads[k];
      ASSERT_FALSE(r.empty());
      if (r[0].kind == AccessKind::Node) {
        EXPECT_EQ(r.size(), 1u);
        EXPECT_EQ(log.independent[k], 1u);
      } else if (r[0].kind == AccessKind::PrimRef) {
        // The first step of a leaf: its list, then the triangles whose indices it holds.
        EXPECT_EQ(log.independent[k], 1u);
        EXPECT_GE(r.size(), 2u);
        EXPECT_LE(r.size(), 5u);
        for (size_t j = 1; j < r.size(); ++j) EXPECT_EQ(r[j].kind, AccessKind::Triangle);
      } else {
        EXPECT_EQ(r[0].kind, AccessKind::Triangle);
        EXPECT_EQ(log.independent[k], r.size());  // later steps: nothing to wait for
      }
    }
    trace_ray(t1, ray);
    // The same work and answer whatever the step size; only any-hit rays read more.
    EXPECT_EQ(t1.counters().ops(), t4.counters().ops()) << i;
    EXPECT_EQ(t1.hit().prim, t4.hit().prim) << i;
    EXPECT_EQ(t1.counters().triangle_fetches, t1.counters().ist_ops);
    if (ray.type == RayType::Primary) EXPECT_EQ(t4.counters().triangle_fetches, t4.counters().ist_ops);
    EXPECT_GE(t4.counters().triangle_fetches, t4.counters().ist_ops);
    over_fetched += t4.counters().triangle_fetches - t4.counters().ist_ops;
  }
  EXPECT_GT(over_fetched, 0u);
}

TEST(CoreTraversal, InlineLeavesReadNoPrimRefs) {
  MemoryLayoutConfig inline_layout;
  inline_layout.triangle_storage = TriangleStorage::Inline;
  SphereScene indexed, in_leaf(inline_layout);
  RayTraversal a(*indexed.context), b(*in_leaf.context);
  for (const Ray& ray : indexed.inside_rays(500)) {
    const StepLog log = drive(b, ray);
    for (const auto& r : log.reads)
      for (const MemoryAccess& m : r) EXPECT_NE(m.kind, AccessKind::PrimRef);
    trace_ray(a, ray);
    EXPECT_EQ(a.hit().prim, b.hit().prim);
    EXPECT_EQ(a.counters().ops(), b.counters().ops());
    EXPECT_EQ(b.counters().prim_ref_fetches, 0u);
  }
}

TEST(CoreTraversal, SpillsAreWritesThatRefillsReadBackInTheSlotsOwnArea) {
  SphereScene deep;
  TraversalConfig shallow;
  shallow.stack_limit = 2;
  const TraversalContext context(deep.scene, deep.bvh, *deep.image, shallow);
  RayTraversal trv(context, 5);
  const uint64_t area = context.stack_area(5);
  EXPECT_GE(area, deep.image->end_address());
  EXPECT_EQ(context.stack_area(6) - area, TraversalContext::kStackAreaEntries * shallow.stack_entry_bytes);
  uint64_t writes = 0, reads = 0;
  for (const Ray& ray : deep.inside_rays(2000)) {
    const StepLog log = drive(trv, ray);
    std::set<uint64_t> written;
    for (const MemoryAccess& a : log.stack) {
      EXPECT_EQ(a.kind, AccessKind::Stack);
      EXPECT_GE(a.address, area);
      EXPECT_LT(a.address, context.stack_area(6));
      if (a.write) {
        written.insert(a.address);
        ++writes;
      } else {
        EXPECT_TRUE(written.count(a.address)) << "a refill reads what a spill wrote";
        ++reads;
      }
    }
    EXPECT_EQ(trv.counters().stack_overflows, std::count_if(log.stack.begin(), log.stack.end(),
                                                              [](const MemoryAccess& a) { return a.write; }));
  }
  EXPECT_GT(writes, 0u);
  EXPECT_GT(reads, 0u);
}
