// The exact referee (exact_referee.h). Signs of edge functions are exact: a
// double evaluation stands where it exceeds a bound on its own rounding error,
// otherwise the determinant is summed exactly as a floating-point expansion
// (Shewchuk's two-sum / two-product arithmetic: every float product and sum is
// kept as a list of non-overlapping doubles whose sum is the exact value).
#include <rtsim/model/core/exact_referee.h>

#include <cfloat>
#include <cmath>
#include <vector>

namespace rtsim {

namespace {

// Non-overlapping components in increasing magnitude, no zeros; the sum is exact.
using Expansion = std::vector<double>;

inline void two_sum(double a, double b, double& sum, double& error) {
  sum = a + b;
  const double b_virtual = sum - a;
  const double a_virtual = sum - b_virtual;
  error = (a - a_virtual) + (b - b_virtual);
}

inline void two_product(double a, double b, double& product, double& error) {
  product = a * b;
  error = std::fma(a, b, -product);  // exact: the rounding error of a * b
}

// e += b, keeping e non-overlapping (Shewchuk's GROW-EXPANSION, zeros dropped).
void grow(Expansion& e, double b) {
  double q = b;
  size_t kept = 0;
  for (size_t i = 0; i < e.size(); ++i) {
    double sum, error;
    two_sum(q, e[i], sum, error);
    q = sum;
    if (error != 0.0) e[kept++] = error;  // kept <= i: reads stay ahead of writes
  }
  e.resize(kept);
  if (q != 0.0) e.push_back(q);
}

int sign_of(const Expansion& e) {
  // In a non-overlapping expansion the largest component decides the sign.
  return e.empty() ? 0 : (e.back() > 0.0 ? 1 : -1);
}

// det[p - o, q - o, d] exactly: each difference is an exact two-term sum, each
// of the six products of the triple product expands into exact terms.
int exact_edge_sign_expansion(const vec3& o, const vec3& d, const vec3& p, const vec3& q) {
  double a[3][2], b[3][2];
  for (int k = 0; k < 3; ++k) {
    two_sum(double(p[k]), -double(o[k]), a[k][0], a[k][1]);
    two_sum(double(q[k]), -double(o[k]), b[k][0], b[k][1]);
  }
  // (a x b) . d = sum over (i, j, k, sign) of sign * a_i * b_j * d_k
  static const int kTerms[6][4] = {{1, 2, 0, +1}, {2, 1, 0, -1}, {2, 0, 1, +1},
                                   {0, 2, 1, -1}, {0, 1, 2, +1}, {1, 0, 2, -1}};
  Expansion total;
  total.reserve(96);
  for (const auto& term : kTerms) {
    const double dk = double(d[term[2]]) * term[3];  // exact: a sign flip
    for (double ai : a[term[0]])
      for (double bj : b[term[1]]) {
        double ab, ab_error;
        two_product(ai, bj, ab, ab_error);
        for (double part : {ab, ab_error}) {
          double abd, abd_error;
          two_product(part, dk, abd, abd_error);
          grow(total, abd_error);
          grow(total, abd);
        }
      }
  }
  return sign_of(total);
}

}  // namespace

int exact_edge_sign(const vec3& origin, const vec3& direction, const vec3& p, const vec3& q) {
  // The double evaluation and a bound on its error: the differences, products and
  // sums make fewer than 16 roundings of relative size DBL_EPSILON / 2 each,
  // measured against the sum of the magnitudes of the terms (the permanent).
  const dvec3 o(origin), d(direction);
  const dvec3 a = dvec3(p) - o, b = dvec3(q) - o;
  const double value = (a.y * b.z - a.z * b.y) * d.x + (a.z * b.x - a.x * b.z) * d.y +
                       (a.x * b.y - a.y * b.x) * d.z;
  const double permanent = (std::fabs(a.y * b.z) + std::fabs(a.z * b.y)) * std::fabs(d.x) +
                           (std::fabs(a.z * b.x) + std::fabs(a.x * b.z)) * std::fabs(d.y) +
                           (std::fabs(a.x * b.y) + std::fabs(a.y * b.x)) * std::fabs(d.z);
  const double bound = 16.0 * DBL_EPSILON * permanent;
  if (value > bound) return 1;
  if (value < -bound) return -1;
  return exact_edge_sign_expansion(origin, direction, p, q);
}

ExactReferee::ExactReferee(const Scene& scene, float relative_bound, float absolute_bound)
    : scene_(scene), relative_bound_(relative_bound), absolute_bound_(absolute_bound) {
  // Each disputed ray meets every instance: their transforms are inverted once.
  world_to_object_.reserve(scene.instances.size());
  for (uint32_t i = 0; i < scene.instances.size(); ++i) world_to_object_.push_back(scene.world_to_object(i));
}

std::vector<RefereeCandidate> ExactReferee::candidates(const Ray& ray) const {
  std::vector<RefereeCandidate> out;
  if (!scene_.instanced()) {
    add_candidates(ray, 0, uint32_t(scene_.triangle_count()), kNoInstance, out);
    return out;
  }
  // Each instance's triangles against the ray in its object space, transformed as
  // the core's Transform step does (Scene::world_to_object, then float): the exact
  // answer for the ray the hardware tests.
  for (uint32_t i = 0; i < scene_.instances.size(); ++i) {
    const glm::mat4& m = world_to_object_[i];
    Ray local = ray;
    local.origin = glm::mat3(m) * ray.origin + vec3(m[3]);
    local.direction = glm::mat3(m) * ray.direction;
    const SceneMesh& mesh = scene_.meshes[scene_.instances[i].mesh];
    add_candidates(local, mesh.first_triangle, mesh.first_triangle + mesh.triangle_count, i, out);
  }
  return out;
}

void ExactReferee::add_candidates(const Ray& ray, uint32_t first, uint32_t end, uint32_t instance,
                                  std::vector<RefereeCandidate>& out) const {
  const dvec3 o(ray.origin), d(ray.direction);
  const long double bound_min = (long double)relative_bound_ * std::fabs(ray.tmin) + absolute_bound_;
  const bool finite_max = std::isfinite(ray.tmax);
  const long double bound_max = finite_max ? (long double)relative_bound_ * ray.tmax + absolute_bound_ : 0;
  const double t_low = double(ray.tmin) - double(bound_min);
  const double t_high = finite_max ? double(ray.tmax) + double(bound_max) : INFINITY;
  for (uint32_t tri = first; tri < end; ++tri) {
    const vec3 v0 = scene_.vertex(tri, 0), v1 = scene_.vertex(tri, 1), v2 = scene_.vertex(tri, 2);
    // Cull by the triangle's box, grown by far more than the rounding of this
    // double slab test, so that no triangle the exact ray touches is culled.
    {
      double t_near = t_low, t_far = t_high;
      bool missed = false;
      for (int k = 0; k < 3 && !missed; ++k) {
        const double lo = std::min({double(v0[k]), double(v1[k]), double(v2[k])});
        const double hi = std::max({double(v0[k]), double(v1[k]), double(v2[k])});
        const double margin = 1e-9 * (std::fabs(lo) + std::fabs(hi) + std::fabs(o[k]) + 1e-30);
        if (d[k] == 0.0) {
          missed = o[k] < lo - margin || o[k] > hi + margin;
          continue;
        }
        double t0 = (lo - margin - o[k]) / d[k], t1 = (hi + margin - o[k]) / d[k];
        if (t0 > t1) std::swap(t0, t1);
        t_near = std::max(t_near, t0 - 1e-9 * std::fabs(t0));
        t_far = std::min(t_far, t1 + 1e-9 * std::fabs(t1));
        missed = t_near > t_far;
      }
      if (missed) continue;
    }
    // The core's edges (intersect.h): (v2, v1), (v0, v2), (v1, v0).
    const int s[3] = {exact_edge_sign(ray.origin, ray.direction, v2, v1),
                      exact_edge_sign(ray.origin, ray.direction, v0, v2),
                      exact_edge_sign(ray.origin, ray.direction, v1, v0)};
    int positive = 0, negative = 0;
    for (int k : s) positive += k > 0, negative += k < 0;
    if (positive && negative) continue;    // outside
    if (!positive && !negative) continue;  // in the triangle's plane, or a degenerate triangle
    using ldvec = long double;
    ldvec e1[3], e2[3], w[3], n[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = ldvec(v1[k]) - ldvec(v0[k]);
      e2[k] = ldvec(v2[k]) - ldvec(v0[k]);
      w[k] = ldvec(v0[k]) - ldvec(ray.origin[k]);
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const ldvec denominator = n[0] * ray.direction[0] + n[1] * ray.direction[1] + n[2] * ray.direction[2];
    if (denominator == 0) continue;
    const ldvec t = (n[0] * w[0] + n[1] * w[1] + n[2] * w[2]) / denominator;
    if (t < (ldvec)ray.tmin - bound_min) continue;
    if (finite_max && t > (ldvec)ray.tmax + bound_max) continue;
    RefereeCandidate c;
    c.prim = tri;
    c.instance = instance;
    c.t = t;
    if (scene_.alpha_tested(tri)) {
      // The barycentrics of the exact hit point p = o + t d (Embree's convention):
      // u = ((p - v0) x e2) . n / |n|^2, v = (e1 x (p - v0)) . n / |n|^2.
      ldvec q[3];
      for (int k = 0; k < 3; ++k) q[k] = -w[k] + t * ldvec(ray.direction[k]);
      const ldvec nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
      const ldvec qe2[3] = {q[1] * e2[2] - q[2] * e2[1], q[2] * e2[0] - q[0] * e2[2], q[0] * e2[1] - q[1] * e2[0]};
      const ldvec e1q[3] = {e1[1] * q[2] - e1[2] * q[1], e1[2] * q[0] - e1[0] * q[2], e1[0] * q[1] - e1[1] * q[0]};
      const float u = float((qe2[0] * n[0] + qe2[1] * n[1] + qe2[2] * n[2]) / nn);
      const float v = float((e1q[0] * n[0] + e1q[1] * n[1] + e1q[2] * n[2]) / nn);
      // The verdict there and a rounding's width around it (float barycentrics of
      // either side may land that far off): one verdict, or both admissible.
      constexpr float kSpread = 1e-4f;
      const bool opaque = scene_.alpha_sample(tri, u, v).opaque;
      bool same = true;
      for (const float du : {-kSpread, kSpread})
        for (const float dv : {-kSpread, kSpread})
          same = same && scene_.alpha_sample(tri, u + du, v + dv).opaque == opaque;
      if (same && !opaque) continue;  // the ray passes through a clear texel
      c.alpha_ambiguous = !same;
    }
    c.on_boundary = positive + negative < 3;
    c.at_endpoint = std::fabs(t - (ldvec)ray.tmin) <= bound_min ||
                    (finite_max && std::fabs((ldvec)ray.tmax - t) <= bound_max);
    out.push_back(c);
  }
}

bool ExactReferee::admissible(const Ray& ray, const std::vector<RefereeCandidate>& candidates,
                              const RayAnswer& answer) const {
  bool any_required = false;
  for (const RefereeCandidate& c : candidates) any_required = any_required || c.required();
  if (traversal_mode_for(ray.type) == TraversalMode::AnyHit)
    return answer.hit ? !candidates.empty() : !any_required;
  if (!answer.hit) return !any_required;
  const long double bound = (long double)relative_bound_ * std::fabs(answer.t) + absolute_bound_;
  const RefereeCandidate* named = nullptr;
  for (const RefereeCandidate& c : candidates)
    if (c.prim == answer.prim && c.instance == answer.instance) named = &c;
  if (!named || std::fabs(named->t - (long double)answer.t) > bound + (long double)relative_bound_ * std::fabs(named->t))
    return false;
  for (const RefereeCandidate& c : candidates)
    if (c.required() && c.t < (long double)answer.t - bound) return false;  // a nearer hit was missed
  return true;
}

}  // namespace rtsim
