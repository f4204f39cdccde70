#pragma once
// Basic geometry shared by every layer: vectors come from GLM, boxes are ours.
#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace rtsim {

using glm::vec3;
using glm::dvec3;
using glm::uvec3;

// Axis-aligned bounding box. An empty box has lo = +inf, hi = -inf so that
// extending it by any point gives that point.
struct Aabb {
  vec3 lo{std::numeric_limits<float>::infinity()};
  vec3 hi{-std::numeric_limits<float>::infinity()};

  static Aabb of_triangle(const vec3& a, const vec3& b, const vec3& c) {
    Aabb box;
    box.extend(a);
    box.extend(b);
    box.extend(c);
    return box;
  }
  void extend(const vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void extend(const Aabb& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  vec3 extent() const { return empty() ? vec3(0.0f) : hi - lo; }
  vec3 centre() const { return 0.5f * (lo + hi); }
  // Surface area; a flat box still has the area of its faces (>= 0, never NaN).
  float area() const {
    const vec3 d = extent();
    return 2.0f * (d.x * d.y + d.y * d.z + d.z * d.x);
  }
  float diagonal() const { return glm::length(extent()); }
  bool contains(const Aabb& b) const {
    return b.lo.x >= lo.x && b.lo.y >= lo.y && b.lo.z >= lo.z && b.hi.x <= hi.x &&
           b.hi.y <= hi.y && b.hi.z <= hi.z;
  }
  static Aabb intersection(const Aabb& a, const Aabb& b) {
    Aabb r;
    r.lo = glm::max(a.lo, b.lo);
    r.hi = glm::min(a.hi, b.hi);
    return r;
  }
};

inline bool is_finite(const vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// 3-D Morton code: the low 21 bits of v spread so that two zero bits follow each;
// (spread(x) | spread(y) << 1 | spread(z) << 2) orders grid cells along a Z curve.
// The face order, the AO sample grouping and the ray-reordering unit share it.
inline uint64_t spread_bits_21(uint64_t v) {
  v &= 0x1FFFFFull;
  v = (v | (v << 32)) & 0x1F00000000FFFFull;
  v = (v | (v << 16)) & 0x1F0000FF0000FFull;
  v = (v | (v << 8)) & 0x100F00F00F00F00Full;
  v = (v | (v << 4)) & 0x10C30C30C30C30C3ull;
  v = (v | (v << 2)) & 0x1249249249249249ull;
  return v;
}

// The Morton code of p's cell on a grid of `cells` (<= 2^21) per axis over box
// (points outside clamp to the nearest cell; a flat axis is cell 0).
inline uint64_t morton_code(const vec3& p, const Aabb& box, uint32_t cells) {
  uint64_t code = 0;
  for (int a = 0; a < 3; ++a) {
    const float extent = box.hi[a] - box.lo[a];
    const float scale = extent > 0 && std::isfinite(extent) ? float(cells - 1) / extent : 0.0f;
    const float cell = std::min(std::max((p[a] - box.lo[a]) * scale, 0.0f), float(cells - 1));
    code |= spread_bits_21(uint64_t(cell)) << a;
  }
  return code;
}

// Cosine-weighted direction over the hemisphere around unit `normal`, from two
// uniform numbers in [0,1): a uniform point on the unit disk lifted to the
// hemisphere (Malley's method), in an orthonormal basis built without a branch on
// a fixed "up" axis (Duff et al. 2017). The model's AO rays and the builders'
// sample rays both use it, so they follow the same distribution.
inline vec3 cosine_hemisphere_direction(const vec3& normal, float r1, float r2) {
  const float radius = std::sqrt(r1);
  const float phi = 6.28318530717958647692f * r2;
  const float lx = radius * std::cos(phi), ly = radius * std::sin(phi);
  const float lz = std::sqrt(std::max(0.0f, 1.0f - r1));
  const float sign = std::copysign(1.0f, normal.z);
  const float a = -1.0f / (sign + normal.z);
  const float b = normal.x * normal.y * a;
  const vec3 tangent(1.0f + sign * normal.x * normal.x * a, sign * b, -sign * normal.x);
  const vec3 bitangent(b, sign + normal.y * normal.y * a, -normal.y);
  return glm::normalize(lx * tangent + ly * bitangent + lz * normal);
}

}  // namespace rtsim
