// EPO against its definition, evaluated the slow way: for every node, every
// triangle not referenced below it, clipped against the node's box. The metric's
// shortcuts (whole subtrees inside the box, triangles wholly inside or outside,
// planes that cut nothing) must not change it, at any width.
#include <rtsim/builder/build.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/workloads/procedural.h>

#include <gtest/gtest.h>

#include <set>

#include "builder/scene_fixtures.h"

namespace rtsim {
namespace {

// Sutherland-Hodgman in double, the six planes in turn.
double clip_area(const Scene& scene, uint32_t t, const Aabb& box) {
  std::vector<dvec3> poly{dvec3(scene.vertex(t, 0)), dvec3(scene.vertex(t, 1)),
                          dvec3(scene.vertex(t, 2))};
  for (int plane = 0; plane < 6 && !poly.empty(); ++plane) {
    const int axis = plane % 3;
    const bool above = plane < 3;
    const double bound = above ? box.lo[axis] : box.hi[axis];
    auto inside = [&](const dvec3& p) { return above ? p[axis] >= bound : p[axis] <= bound; };
    std::vector<dvec3> next;
    for (size_t i = 0; i < poly.size(); ++i) {
      const dvec3 p = poly[i], q = poly[(i + 1) % poly.size()];
      if (inside(p)) next.push_back(p);
      if (inside(p) != inside(q)) {
        dvec3 x = p + (bound - p[axis]) / (q[axis] - p[axis]) * (q - p);
        x[axis] = bound;
        next.push_back(x);
      }
    }
    poly = next;
  }
  if (poly.size() < 3) return 0;
  dvec3 sum(0.0);
  for (size_t i = 1; i + 1 < poly.size(); ++i) sum += glm::cross(poly[i] - poly[0], poly[i + 1] - poly[0]);
  return 0.5 * glm::length(sum);
}

void below(const Bvh& bvh, uint32_t node, std::set<uint32_t>* out) {
  const BvhNode& n = bvh.nodes[node];
  if (n.is_leaf()) {
    for (uint32_t k = n.index; k < n.index + n.count; ++k) out->insert(bvh.prim_refs[k]);
    return;
  }
  for (uint32_t c = n.index; c < n.index + n.children; ++c) below(bvh, c, out);
}

double slow_epo(const Bvh& bvh, const Scene& scene, float t1, float t2) {
  double total = 0;
  for (uint32_t t = 0; t < scene.triangle_count(); ++t)
    total += clip_area(scene, t, scene.bounds());
  double sum = 0;
  for (uint32_t node = 1; node < bvh.nodes.size(); ++node) {
    std::set<uint32_t> mine;
    below(bvh, node, &mine);
    double area = 0;
    for (uint32_t t = 0; t < scene.triangle_count(); ++t)
      if (!mine.count(t)) area += clip_area(scene, t, bvh.nodes[node].bounds);
    const BvhNode& n = bvh.nodes[node];
    sum += (n.is_leaf() ? double(t2) * n.count : 2.0 * t1) * area;
  }
  return sum / total;
}

TEST(Epo, MatchesTheDefinitionForEveryKindOfTree) {
  const Scene scenes[] = {make_procedural_scene("cornell"), test::triangle_soup(600, 4, 0.3f)};
  for (const Scene& scene : scenes)
    for (const char* builder : {"sah", "median", "sbvh", "embree"})
      for (uint32_t width : {2u, 4u, 8u}) {
        BuildParams p;
        p.builder = builder;
        p.width = width;
        p.t2 = 1.5f;
        const Bvh bvh = build_bvh(scene, p);
        const double fast = end_point_overlap(bvh, scene, p.t1, p.t2);
        const double slow = slow_epo(bvh, scene, p.t1, p.t2);
        EXPECT_GT(slow, 0) << scene.name << " " << builder << " width " << width;
        // The metric totals the triangle areas from float edge vectors: ~1e-9 apart.
        EXPECT_NEAR(fast, slow, 1e-7 * slow) << scene.name << " " << builder << " width " << width;
      }
}

}  // namespace
}  // namespace rtsim
