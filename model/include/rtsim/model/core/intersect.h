#pragma once
// Robust ray-box and watertight ray-triangle tests, inline because they are the
// inner loop of the functional core.
#include <rtsim/workloads/geometry.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

// RTSIM_SSE2: the lane tests below use SSE2 (every x86-64 has it). A build with
// RTSIM_SIMD=OFF (RTSIM_NO_SIMD) takes the scalar fallback instead, the path a
// machine without SSE2 would take, so that path is built and tested here too.
#if defined(__SSE2__) && !defined(RTSIM_NO_SIMD)
#define RTSIM_SSE2 1
#include <emmintrin.h>
#endif

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

// Child boxes laid out for one 4-lane slab test: plane[0][axis] holds the boxes'
// lo on that axis, plane[1][axis] their hi, kLanes to a row. A wide record's boxes
// are a run of quads (kLanes = 4; the traversal context builds them once); a binary
// record's are one pair (kLanes = 2), half a quad's bytes, whose rows load into the
// low two lanes. Lanes past the node's children are unused and masked off by the
// caller.
template <int kLanes>
struct BoxLanes {
  static_assert(kLanes == 2 || kLanes == 4, "rows of two or four lanes");
  alignas(16) float plane[2][3][kLanes];
  void set(int slot, const Aabb& box) {  // slot 0..kLanes-1
    for (int a = 0; a < 3; ++a) plane[0][a][slot] = box.lo[a], plane[1][a][slot] = box.hi[a];
  }
};
using BoxQuadLanes = BoxLanes<4>;
using BoxPairLanes = BoxLanes<2>;

// The ray's slab-test data broadcast to four lanes, made once per ray, with the
// byte offsets in a BoxQuadLanes of the rows it enters and leaves by per axis
// (its direction's signs), so that a node step only loads.
struct RayBoxLanes {
#if defined(RTSIM_SSE2)
  __m128 origin[3], inv_direction[3];
#endif
  size_t near_row_offset[3] = {0, 0, 0}, far_row_offset[3] = {0, 0, 0};
  RayBoxPrecompute scalar;
  RayBoxLanes() = default;
  explicit RayBoxLanes(const RayBoxPrecompute& r) : scalar(r) {
    for (int a = 0; a < 3; ++a) {
      near_row_offset[a] = sizeof(BoxQuadLanes::plane[0]) * size_t(r.near_is_hi[a]) + sizeof(BoxQuadLanes::plane[0][0]) * size_t(a);
      far_row_offset[a] = sizeof(BoxQuadLanes::plane[0]) * size_t(1 - r.near_is_hi[a]) + sizeof(BoxQuadLanes::plane[0][0]) * size_t(a);
#if defined(RTSIM_SSE2)
      origin[a] = _mm_set1_ps(r.origin[a]);
      inv_direction[a] = _mm_set1_ps(r.inv_direction[a]);
#endif
    }
  }
};

// intersect_box for the boxes of a quad (or a pair) at once, with exactly its
// answers (the same operations in the same order per lane, so traversal is
// bit-identical): the ray's sign picks which plane row is near per axis (an
// address, not a blend), max and min keep the running bound when a distance is NaN
// as the scalar test does. Returns a hit mask (bit i: box i) and writes four entry
// distances (a pair's lanes 2 and 3 test empty planes: the caller masks them off).
template <int kLanes>
inline uint32_t intersect_box_lanes(const RayBoxLanes& r, const BoxLanes<kLanes>& boxes, float tmin,
                                    float tmax, float t_entry[4]) {
#if defined(RTSIM_SSE2)
  constexpr float kFarScale = 1.0f + 2.0f * float_gamma(3);
  const __m128 scale = _mm_set1_ps(kFarScale);
  const char* rows = reinterpret_cast<const char*>(&boxes);
  // The ray's offsets are a quad's; a pair's rows are half as long.
  const auto row = [&](size_t quad_offset) {
    const char* p = rows + quad_offset * kLanes / 4;
    if constexpr (kLanes == 4) return _mm_load_ps(reinterpret_cast<const float*>(p));
    else return _mm_castpd_ps(_mm_load_sd(reinterpret_cast<const double*>(p)));
  };
  __m128 t_near = _mm_set1_ps(tmin), t_far = _mm_set1_ps(tmax);
  for (int a = 0; a < 3; ++a) {
    const __m128 near_plane = row(r.near_row_offset[a]);
    const __m128 far_plane = row(r.far_row_offset[a]);
    const __m128 t0 = _mm_mul_ps(_mm_sub_ps(near_plane, r.origin[a]), r.inv_direction[a]);
    const __m128 t1 = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(far_plane, r.origin[a]), r.inv_direction[a]), scale);
    t_near = _mm_max_ps(t0, t_near);  // t0 > t_near ? t0 : t_near
    t_far = _mm_min_ps(t1, t_far);    // t1 < t_far ? t1 : t_far
  }
  _mm_storeu_ps(t_entry, t_near);
  return uint32_t(_mm_movemask_ps(_mm_cmple_ps(t_near, t_far)));
#else
  uint32_t mask = 0;
  for (int slot = 0; slot < kLanes; ++slot) {
    Aabb box;
    for (int a = 0; a < 3; ++a) box.lo[a] = boxes.plane[0][a][slot], box.hi[a] = boxes.plane[1][a][slot];
    if (intersect_box(r.scalar, box, tmin, tmax, &t_entry[slot])) mask |= 1u << slot;
  }
  for (int slot = kLanes; slot < 4; ++slot) t_entry[slot] = tmin;
  return mask;
#endif
}

// Per-ray data for the watertight test (Woop, Benthin, Wald 2013): the ray is
// permuted so its dominant axis is z, then sheared onto +z.
struct RayTrianglePrecompute {
  vec3 origin{0.0f};
  vec3 direction{0.0f, 0.0f, 1.0f};
  int kx = 0, ky = 1, kz = 2;
  float shear_x = 0.0f, shear_y = 0.0f, shear_z = 1.0f;

  RayTrianglePrecompute() = default;
  RayTrianglePrecompute(const vec3& o, const vec3& d) : origin(o), direction(d) {
    // Components indexed in an array (glm's operator[] is a switch), and the axes
    // found by a table and a mask: an AO ray's dominant axis and sign are random,
    // so any branch on them is mispredicted about once a ray.
    const float dv[3] = {d.x, d.y, d.z};
    const float ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
    // kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2), indexed by the three comparisons.
    static constexpr int kDominant[8] = {2, 2, 2, 0, 1, 2, 1, 0};
    static constexpr int kNext[3] = {1, 2, 0};
    kz = kDominant[int(ax > ay) | int(ax > az) << 1 | int(ay > az) << 2];
    const int next_x = kNext[kz], next_y = kNext[next_x];
    // Swapping x and y when the ray runs toward -z keeps the winding, so signs stay meaningful.
    const int flip = -int(dv[kz] < 0.0f);  // all ones or zero
    kx = next_x ^ ((next_x ^ next_y) & flip);
    ky = next_x ^ next_y ^ kx;
    shear_x = dv[kx] / dv[kz];
    shear_y = dv[ky] / dv[kz];
    shear_z = 1.0f / dv[kz];
  }
};

struct TriangleHit {
  float t, u, v;  // u, v: weights of v1, v2 (Embree's convention)
};

namespace triangle_detail {

// A vertex in the ray's sheared 2D frame (origin at the ray), with what the
// error bounds need: |x|, |y|, and the magnitudes of the terms that formed each
// coordinate.
struct ShearedVertex {
  const vec3* vertex;
  float z;     // (vertex - origin)[kz], rounded to float
  float x, y;  // sheared coordinates
  float ax, ay;  // |x|, |y|
  float mx, my;  // |p[kx]| + |shear_x p[kz]|, likewise for y
};

inline ShearedVertex shear(const RayTrianglePrecompute& r, const vec3& vertex) {
  const vec3 d = vertex - r.origin;
  const float p[3] = {d.x, d.y, d.z};  // indexed without glm's switch (see RayTrianglePrecompute)
  const float sx = r.shear_x * p[r.kz], sy = r.shear_y * p[r.kz];
  const float x = p[r.kx] - sx, y = p[r.ky] - sy;
  return {&vertex,      p[r.kz], x, y, std::fabs(x), std::fabs(y), std::fabs(p[r.kx]) + std::fabs(sx),
          std::fabs(p[r.ky]) + std::fabs(sy)};
}

[[gnu::noinline, gnu::cold]] inline float edge_function_in_double(const RayTrianglePrecompute& r,
                                                                  const vec3& p, const vec3& q,
                                                                  uint32_t* exact_steps) {
  if (exact_steps) ++*exact_steps;
  const dvec3 o(r.origin);
  const double triple = glm::dot(glm::cross(dvec3(p) - o, dvec3(q) - o), dvec3(r.direction));
  return float(triple / std::fabs(double(r.direction[r.kz])));
}

// The edge function of the directed edge (p, q): its sign says on which side of
// the edge the ray passes. The float value stands when its sign is certain: its
// magnitude exceeds a bound on its rounding error.
//  - Each sheared coordinate is off by at most gamma(6) times its term magnitude
//    m (the difference from the origin, the rounded shear, the product and the
//    difference). So p.x q.y is off by at most
//    gamma(6) (m_px |q.y| + |p.x| m_qy) + gamma(6)^2 m_px m_qy, likewise p.y q.x,
//    plus the rounding of the products and of their difference. The constants
//    below (gamma(16), gamma(8)^2) cover all that and the rounding of the bound.
//  - The bound scales with the triangle's size times its distance, not with the
//    distance squared, so small, far triangles stay on the float path.
// Otherwise the value is recomputed in double from the unsheared vectors, as
// det[p - o, q - o, d] / |d_kz|, which the sheared value equals in exact
// arithmetic. So a ray in or near the triangle's plane, or through an edge, gets
// the double verdict instead of a sign made of rounding error.
// Watertightness needs a shared edge to get one sign (negated) from both of its
// triangles. Every input here belongs to the edge alone, each expression is
// exactly antisymmetric in (p, q) under IEEE rounding, and the bound is exactly
// symmetric (its sums pair the same products, and float + and * commute).
inline float edge_function(const RayTrianglePrecompute& r, const ShearedVertex& p,
                           const ShearedVertex& q, float* bound, uint32_t* exact_steps) {
  const float value = p.x * q.y - p.y * q.x;
  const float first_order = (p.mx * q.ay + p.ax * q.my) + (p.my * q.ax + p.ay * q.mx);
  const float second_order = p.mx * q.my + p.my * q.mx;
  *bound = float_gamma(16) * first_order + float_gamma(8) * float_gamma(8) * second_order;
  if (std::fabs(value) > *bound) return value;
  return edge_function_in_double(r, *p.vertex, *q.vertex, exact_steps);
}

// The distance to the triangle's plane, computed in double; false when the ray
// is parallel to it in double or the distance is outside [tmin, tmax].
[[gnu::noinline, gnu::cold]] inline bool plane_distance_in_double(
    const RayTrianglePrecompute& r, const vec3& v0, const vec3& v1, const vec3& v2, float tmin,
    float tmax, float* t, uint32_t* exact_steps) {
  if (exact_steps) ++*exact_steps;
  const dvec3 n = glm::cross(dvec3(v1) - dvec3(v0), dvec3(v2) - dvec3(v0));
  const double denominator = glm::dot(n, dvec3(r.direction));
  if (denominator == 0.0) return false;
  const double td = glm::dot(n, dvec3(v0) - dvec3(r.origin)) / denominator;
  if (!(td >= double(tmin) && td <= double(tmax))) return false;
  *t = float(td);  // rounding keeps it within [tmin, tmax]; it may overflow (see caller)
  return true;
}

}  // namespace triangle_detail

// Watertight: a ray through a shared edge or vertex hits at least one of the
// triangles sharing it. Both windings hit (no culling). A degenerate triangle
// (zero determinant) never hits. Hits with t in [tmin, tmax] only.
// Where float rounding could decide the verdict (an edge function, or the
// determinant, within its error bound) the decision is taken in double, so the
// verdict is that of double precision (see edge_function); the common case
// stays in float. `exact_steps`, when given, counts the steps taken in double
// (edge functions and plane distances): how often a hardware IST unit would need
// its slow path.
inline bool intersect_triangle(const RayTrianglePrecompute& r, const vec3& v0, const vec3& v1,
                               const vec3& v2, float tmin, float tmax, TriangleHit* out,
                               uint32_t* exact_steps = nullptr) {
  using namespace triangle_detail;
  const ShearedVertex a = shear(r, v0), b = shear(r, v1), c = shear(r, v2);
  float bound_u, bound_v, bound_w;
  const float u = edge_function(r, c, b, &bound_u, exact_steps);
  const float v = edge_function(r, a, c, &bound_v, exact_steps);
  const float w = edge_function(r, b, a, &bound_w, exact_steps);
  if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) return false;
  const float det = u + v + w;
  if (det == 0.0f) return false;
  const float inv_det = 1.0f / det;
  float t;
  // The float t = scaled_t / det is only as good as det; where det is within
  // 256 times its error bound (the ray nearly parallel to the plane), take the
  // plane distance in double, and no hit when the ray is parallel in double.
  if (std::fabs(det) > 256.0f * (bound_u + bound_v + bound_w)) {
    const float az = r.shear_z * a.z, bz = r.shear_z * b.z, cz = r.shear_z * c.z;
    t = (u * az + v * bz + w * cz) * inv_det;
    if (!(t >= tmin && t <= tmax)) return false;  // also rejects NaN
  } else if (!plane_distance_in_double(r, v0, v1, v2, tmin, tmax, &t, exact_steps)) {
    return false;
  }
  if (std::isinf(t)) return false;  // a distance beyond float range (tmax = inf) is no hit
  out->t = t;
  out->u = v * inv_det;
  out->v = w * inv_det;
  return true;
}

// The ray's watertight-test data broadcast to four lanes, made once per ray: its
// origin permuted to (kx, ky, kz), the shear, and the permutation to apply to
// the triangles' vertices.
struct RayTriangleLanes {
#if defined(RTSIM_SSE2)
  __m128 origin[3], shear_x, shear_y, shear_z;
#endif
  int kx = 0, ky = 1, kz = 2;
  RayTriangleLanes() = default;
  explicit RayTriangleLanes(const RayTrianglePrecompute& r) : kx(r.kx), ky(r.ky), kz(r.kz) {
#if defined(RTSIM_SSE2)
    const float o[3] = {r.origin.x, r.origin.y, r.origin.z};  // indexed without glm's switch
    origin[0] = _mm_set1_ps(o[r.kx]);
    origin[1] = _mm_set1_ps(o[r.ky]);
    origin[2] = _mm_set1_ps(o[r.kz]);
    shear_x = _mm_set1_ps(r.shear_x);
    shear_y = _mm_set1_ps(r.shear_y);
    shear_z = _mm_set1_ps(r.shear_z);
#endif
  }
};

// intersect_triangle's verdicts on four triangles at once, for the lanes it can
// decide in float. Lane k is `exact` where the scalar test would take a step in
// double (an uncertain edge function, or a determinant too close to zero for
// the float distance): the caller runs intersect_triangle on it, which takes
// those steps and counts them. Every other lane is the scalar test's verdict
// bit for bit (the same operations in the same order; the build has no FMA
// contraction): `hit` with t, u, v, for hits with t in [tmin, tmax].
// Since t does not depend on tmax, a lane hit stays exactly the scalar verdict
// for any smaller tmax >= t: the caller may narrow tmax lane by lane as it commits.
struct TriangleQuadVerdict {
  uint32_t hit = 0, exact = 0;  // bit k: lane k
  alignas(16) float t[4], u[4], v[4];
};

// `vertices`: four triangles of nine floats each (v0, v1, v2), one after another;
// all 36 floats must be readable, lanes past the caller's count are ignored.
inline TriangleQuadVerdict intersect_triangle_quad(const RayTriangleLanes& r, const float* vertices,
                                                   float tmin, float tmax) {
  TriangleQuadVerdict out;
#if defined(RTSIM_SSE2)
  // Four rows of nine floats to nine lanes of four: floats 0-3 and 4-7 of each
  // triangle by two 4x4 transposes, float 8 gathered.
  __m128 c[9];
  c[0] = _mm_loadu_ps(vertices), c[1] = _mm_loadu_ps(vertices + 9);
  c[2] = _mm_loadu_ps(vertices + 18), c[3] = _mm_loadu_ps(vertices + 27);
  _MM_TRANSPOSE4_PS(c[0], c[1], c[2], c[3]);
  c[4] = _mm_loadu_ps(vertices + 4), c[5] = _mm_loadu_ps(vertices + 13);
  c[6] = _mm_loadu_ps(vertices + 22), c[7] = _mm_loadu_ps(vertices + 31);
  _MM_TRANSPOSE4_PS(c[4], c[5], c[6], c[7]);
  c[8] = _mm_set_ps(vertices[35], vertices[26], vertices[17], vertices[8]);
  const __m128 sign_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  const auto abs = [&](__m128 x) { return _mm_and_ps(x, sign_mask); };
  struct Sheared {
    __m128 z, x, y, ax, ay, mx, my;  // as triangle_detail::ShearedVertex; z = p[kz]
  };
  const auto shear = [&](int vertex) {
    const __m128* p = c + 3 * vertex;
    const __m128 px = _mm_sub_ps(p[r.kx], r.origin[0]), py = _mm_sub_ps(p[r.ky], r.origin[1]);
    const __m128 pz = _mm_sub_ps(p[r.kz], r.origin[2]);
    const __m128 sx = _mm_mul_ps(r.shear_x, pz), sy = _mm_mul_ps(r.shear_y, pz);
    Sheared s;
    s.z = pz;
    s.x = _mm_sub_ps(px, sx), s.y = _mm_sub_ps(py, sy);
    s.ax = abs(s.x), s.ay = abs(s.y);
    s.mx = _mm_add_ps(abs(px), abs(sx)), s.my = _mm_add_ps(abs(py), abs(sy));
    return s;
  };
  const Sheared a = shear(0), b = shear(1), cv = shear(2);
  const __m128 gamma16 = _mm_set1_ps(float_gamma(16));
  const __m128 gamma8_squared = _mm_set1_ps(float_gamma(8) * float_gamma(8));
  __m128 uncertain = _mm_setzero_ps();
  const auto edge = [&](const Sheared& p, const Sheared& q, __m128* bound) {
    const __m128 value = _mm_sub_ps(_mm_mul_ps(p.x, q.y), _mm_mul_ps(p.y, q.x));
    const __m128 first_order = _mm_add_ps(_mm_add_ps(_mm_mul_ps(p.mx, q.ay), _mm_mul_ps(p.ax, q.my)),
                                          _mm_add_ps(_mm_mul_ps(p.my, q.ax), _mm_mul_ps(p.ay, q.mx)));
    const __m128 second_order = _mm_add_ps(_mm_mul_ps(p.mx, q.my), _mm_mul_ps(p.my, q.mx));
    *bound = _mm_add_ps(_mm_mul_ps(gamma16, first_order), _mm_mul_ps(gamma8_squared, second_order));
    // Not (|value| > bound), so a NaN is uncertain, as in the scalar test.
    uncertain = _mm_or_ps(uncertain, _mm_cmpngt_ps(abs(value), *bound));
    return value;
  };
  __m128 bound_u, bound_v, bound_w;
  const __m128 u = edge(cv, b, &bound_u), v = edge(a, cv, &bound_v), w = edge(b, a, &bound_w);
  const __m128 zero = _mm_setzero_ps();
  const __m128 some_negative = _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)), _mm_cmplt_ps(w, zero));
  const __m128 some_positive = _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)), _mm_cmpgt_ps(w, zero));
  const __m128 det = _mm_add_ps(_mm_add_ps(u, v), w);
  // Lanes that pass the sign test with a nonzero determinant go on to the distance.
  const __m128 candidate = _mm_andnot_ps(_mm_or_ps(_mm_and_ps(some_negative, some_positive), _mm_cmpeq_ps(det, zero)),
                                         _mm_castsi128_ps(_mm_set1_epi32(-1)));
  const __m128 inv_det = _mm_div_ps(_mm_set1_ps(1.0f), det);
  const __m128 det_certain = _mm_cmpgt_ps(
      abs(det), _mm_mul_ps(_mm_set1_ps(256.0f), _mm_add_ps(_mm_add_ps(bound_u, bound_v), bound_w)));
  const __m128 az = _mm_mul_ps(r.shear_z, a.z), bz = _mm_mul_ps(r.shear_z, b.z), cz = _mm_mul_ps(r.shear_z, cv.z);
  const __m128 t = _mm_mul_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)), _mm_mul_ps(w, cz)), inv_det);
  const __m128 in_range = _mm_and_ps(_mm_and_ps(_mm_cmpge_ps(t, _mm_set1_ps(tmin)), _mm_cmple_ps(t, _mm_set1_ps(tmax))),
                                     _mm_cmpneq_ps(abs(t), _mm_set1_ps(std::numeric_limits<float>::infinity())));
  const uint32_t uncertain_mask = uint32_t(_mm_movemask_ps(uncertain));
  const uint32_t candidate_mask = uint32_t(_mm_movemask_ps(candidate));
  out.exact = uncertain_mask | (candidate_mask & ~uint32_t(_mm_movemask_ps(det_certain)));
  out.hit = candidate_mask & uint32_t(_mm_movemask_ps(in_range)) & ~out.exact;
  _mm_store_ps(out.t, t);
  _mm_store_ps(out.u, _mm_mul_ps(v, inv_det));
  _mm_store_ps(out.v, _mm_mul_ps(w, inv_det));
#else
  (void)r, (void)vertices, (void)tmin, (void)tmax;
  out.exact = 0xf;  // no lanes: every triangle takes the scalar test
  for (int k = 0; k < 4; ++k) out.t[k] = out.u[k] = out.v[k] = 0.0f;  // the caller copies them before it asks
#endif
  return out;
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
