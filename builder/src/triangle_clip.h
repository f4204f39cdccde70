#pragma once
// Cutting a triangle (not its box) at an axis-aligned plane, the step spatial
// splits are made of. Our SBVH (its scalar path; the SSE path does the same
// lane for lane) and Embree's split callback share it, so the two builders cut
// triangles alike.
#include <rtsim/workloads/geometry.h>

#include <algorithm>

namespace rtsim::detail {

// The boxes of the parts of triangle `v` on each side of the plane at `position`
// on `axis` (points on the plane in both), each within `within` and its side of
// the plane. A side the triangle does not reach comes out empty.
inline void clip_triangle(const vec3 v[3], int axis, float position, const Aabb& within,
                          Aabb* left, Aabb* right) {
  Aabb l, r;
  for (int e = 0; e < 3; ++e) {
    const vec3& a = v[e];
    const vec3& b = v[(e + 1) % 3];
    if (a[axis] <= position) l.extend(a);
    if (a[axis] >= position) r.extend(a);
    if ((a[axis] < position && position < b[axis]) || (b[axis] < position && position < a[axis])) {
      const float t = (position - a[axis]) / (b[axis] - a[axis]);
      vec3 p = a + t * (b - a);
      p = glm::clamp(p, glm::min(a, b), glm::max(a, b));
      p[axis] = position;
      l.extend(p);
      r.extend(p);
    }
  }
  l = Aabb::intersection(l, within);
  r = Aabb::intersection(r, within);
  l.hi[axis] = std::min(l.hi[axis], position);
  r.lo[axis] = std::max(r.lo[axis], position);
  *left = l;
  *right = r;
}

}  // namespace rtsim::detail
