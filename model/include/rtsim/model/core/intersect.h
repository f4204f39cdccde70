#pragma once
// Robust ray-box and watertight ray-triangle tests, inline because they are the
// inner loop of the functional core.
#include <rtsim/workloads/geometry.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace rtsim {

// gamma(n) = n*u / (1 - n*u), u = 2^-24 (pbrt's bound on n rounded float ops).
constexpr float float_gamma(int n) {
  constexpr float u = 0.5f * std::numeric_limits<float>::epsilon();
  return (float(n) * u) / (1.0f - float(n) * u);
}

// Per-ray data for the slab test.
struct RayBoxPrecompute {
  vec3 origin{0.0f};
  vec3 inv_direction{0.0f};  // 1/d; +-inf for a +-0 component
  int near_is_hi[3] = {0, 0, 0};  // sign bit of d per axis: which plane the ray enters by

  RayBoxPrecompute() = default;
  RayBoxPrecompute(const vec3& o, const vec3& d) : origin(o) {
    for (int a = 0; a < 3; ++a) {
      inv_direction[a] = 1.0f / d[a];  // IEEE: 1/+0 = +inf, 1/-0 = -inf
      near_is_hi[a] = std::signbit(d[a]) ? 1 : 0;
    }
  }
};

// Slab test against [tmin, tmax]. Returns true and the entry distance when the
// ray's interval overlaps the box (faces inclusive).
//  - Zero direction components give infinite slab distances. The one undefined
//    product, 0 * inf (origin exactly on a face plane of a slab the ray runs
//    parallel to), is NaN; it is ignored below, which treats the ray as inside
//    that slab - the inclusive answer.
//  - The far distance is scaled by 1 + 2*gamma(3) (Ize 2013) so that rounding in
//    (plane - origin) * inv_direction can never make the far plane come before a
//    true entry: no false misses on boxes that tightly bound the geometry.
inline bool intersect_box(const RayBoxPrecompute& r, const Aabb& box, float tmin, float tmax,
                          float* t_entry) {
  constexpr float kFarScale = 1.0f + 2.0f * float_gamma(3);
  float t_near = tmin, t_far = tmax;
  for (int a = 0; a < 3; ++a) {
    const float near_plane = r.near_is_hi[a] ? box.hi[a] : box.lo[a];
    const float far_plane = r.near_is_hi[a] ? box.lo[a] : box.hi[a];
    const float t0 = (near_plane - r.origin[a]) * r.inv_direction[a];
    const float t1 = (far_plane - r.origin[a]) * r.inv_direction[a] * kFarScale;
    // Written so that a NaN t0/t1 leaves the running bound unchanged.
    t_near = t0 > t_near ? t0 : t_near;
    t_far = t1 < t_far ? t1 : t_far;
  }
  *t_entry = t_near;
  return t_near <= t_far;
}

// Per-ray data for the watertight test (Woop, Benthin, Wald 2013): the ray is
// permuted so its dominant axis is z, then sheared onto +z.
struct RayTrianglePrecompute {
  vec3 origin{0.0f};
  int kx = 0, ky = 1, kz = 2;
  float shear_x = 0.0f, shear_y = 0.0f, shear_z = 1.0f;

  RayTrianglePrecompute() = default;
  RayTrianglePrecompute(const vec3& o, const vec3& d) : origin(o) {
    const vec3 ad = glm::abs(d);
    kz = (ad.x > ad.y) ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
    kx = (kz + 1) % 3;
    ky = (kx + 1) % 3;
    if (d[kz] < 0.0f) std::swap(kx, ky);  // keeps the winding, so signs stay meaningful
    shear_x = d[kx] / d[kz];
    shear_y = d[ky] / d[kz];
    shear_z = 1.0f / d[kz];
  }
};

struct TriangleHit {
  float t, u, v;  // u, v: weights of v1, v2 (Embree's convention)
};

// Watertight: a ray through a shared edge or vertex hits at least one of the
// triangles sharing it. Both windings hit (no culling). A degenerate triangle
// (zero determinant) never hits. Hits with t in [tmin, tmax] only.
inline bool intersect_triangle(const RayTrianglePrecompute& r, const vec3& v0, const vec3& v1,
                               const vec3& v2, float tmin, float tmax, TriangleHit* out) {
  const vec3 a = v0 - r.origin, b = v1 - r.origin, c = v2 - r.origin;
  const float ax = a[r.kx] - r.shear_x * a[r.kz], ay = a[r.ky] - r.shear_y * a[r.kz];
  const float bx = b[r.kx] - r.shear_x * b[r.kz], by = b[r.ky] - r.shear_y * b[r.kz];
  const float cx = c[r.kx] - r.shear_x * c[r.kz], cy = c[r.ky] - r.shear_y * c[r.kz];
  float u = cx * by - cy * bx;
  float v = ax * cy - ay * cx;
  float w = bx * ay - by * ax;
  if (u == 0.0f || v == 0.0f || w == 0.0f) {
    // An edge function that rounds to exactly zero in float may have the wrong
    // sign; products of floats are exact in double, so redo all three there.
    const double ud = double(cx) * double(by) - double(cy) * double(bx);
    const double vd = double(ax) * double(cy) - double(ay) * double(cx);
    const double wd = double(bx) * double(ay) - double(by) * double(ax);
    if ((ud < 0.0 || vd < 0.0 || wd < 0.0) && (ud > 0.0 || vd > 0.0 || wd > 0.0)) return false;
    u = float(ud);
    v = float(vd);
    w = float(wd);
  } else if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) {
    return false;
  }
  const float det = u + v + w;
  if (det == 0.0f) return false;
  const float az = r.shear_z * a[r.kz], bz = r.shear_z * b[r.kz], cz = r.shear_z * c[r.kz];
  const float scaled_t = u * az + v * bz + w * cz;
  const float inv_det = 1.0f / det;
  const float t = scaled_t * inv_det;
  if (!(t >= tmin && t <= tmax)) return false;  // also rejects NaN
  out->t = t;
  out->u = v * inv_det;
  out->v = w * inv_det;
  return true;
}

// Moves a surface point off the surface along the unit normal `n` (pointing to
// the side the new ray leaves on) so that the new ray cannot hit the surface it
// starts on (Waechter & Binder 2019). The step is a fixed number of float ulps
// of each coordinate, so it scales with the point's magnitude; near the origin,
// where ulps get tiny, a small absolute step is used instead.
inline vec3 offset_ray_origin(const vec3& p, const vec3& n) {
  constexpr float kNearOrigin = 1.0f / 32.0f;
  constexpr float kAbsoluteStep = 1.0f / 65536.0f;
  constexpr float kUlpSteps = 256.0f;
  vec3 result;
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(p[a]) < kNearOrigin) {
      result[a] = p[a] + kAbsoluteStep * n[a];
      continue;
    }
    const int32_t step = int32_t(kUlpSteps * n[a]);
    int32_t bits;
    std::memcpy(&bits, &p[a], sizeof bits);
    bits += (p[a] < 0.0f) ? -step : step;  // sign-magnitude: moving away from 0 = bigger bits
    std::memcpy(&result[a], &bits, sizeof bits);
  }
  return result;
}

}  // namespace rtsim
