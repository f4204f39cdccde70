#include <rtsim/builder/occlusion.h>
#include <rtsim/workloads/progress.h>
#include <rtsim/workloads/random.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>

namespace rtsim {

namespace {
// An orthonormal frame around n (Duff et al. 2017 construction).
void frame(const vec3& n, vec3* t, vec3* b) {
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float c = n.x * n.y * a;
  *t = vec3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
  *b = vec3(c, sign + n.y * n.y * a, -n.y);
}
}  // namespace

std::vector<float> estimate_occlusion(const Scene& scene, const EmbreeScene& embree,
                                      const OcclusionParams& params) {
  const size_t n = scene.triangle_count();
  std::vector<float> values(n, 1.0f);
  if (params.rays == 0 || !(params.cutoff > 0)) return values;
  const uint32_t k = params.rays;
  // Stratify the K start points over a near-square grid of the unit square.
  const uint32_t grid_x = std::max<uint32_t>(1, uint32_t(std::ceil(std::sqrt(double(k)))));
  const uint32_t grid_y = (k + grid_x - 1) / grid_x;
  // Lift the origin off the surface so a ray cannot hit its own triangle.
  const float offset = 1e-5f * std::max(scene.diagonal(), 1e-30f);
  Progress progress("AO rays", n, "triangles");
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t tri = r.begin(); tri != r.end(); ++tri) {
      const vec3 v0 = scene.vertex(uint32_t(tri), 0), v1 = scene.vertex(uint32_t(tri), 1),
                 v2 = scene.vertex(uint32_t(tri), 2);
      const vec3 cross = glm::cross(v1 - v0, v2 - v0);
      const float len = glm::length(cross);
      if (!(len > 0) || !std::isfinite(len)) continue;  // zero area: value 1 (see header)
      const vec3 normal = cross / len;
      vec3 tangent, bitangent;
      frame(normal, &tangent, &bitangent);
      double sum = 0;
      for (uint32_t s = 0; s < k; ++s) {
        KeyedRng rng(params.seed, {0xA0A0ull, tri, s});
        const float u1 = (float(s % grid_x) + rng.next_float()) / float(grid_x);
        const float u2 = (float((s / grid_x) % grid_y) + rng.next_float()) / float(grid_y);
        const float su = std::sqrt(u1);
        const vec3 point = (1.0f - su) * v0 + su * (1.0f - u2) * v1 + su * u2 * v2;
        // Cosine-weighted direction (Malley: uniform disc lifted to the hemisphere).
        const float r1 = rng.next_float(), r2 = rng.next_float();
        const float radius = std::sqrt(r1), phi = 6.28318530718f * r2;
        const float side = (params.both_sides && (s & 1u)) ? -1.0f : 1.0f;
        const vec3 local(radius * std::cos(phi), radius * std::sin(phi),
                         std::sqrt(std::max(0.0f, 1.0f - r1)));
        const vec3 dir = glm::normalize(local.x * tangent + local.y * bitangent +
                                        side * local.z * normal);
        const EmbreeHit hit = embree.intersect(point + side * offset * normal, dir, 0.0f,
                                               params.cutoff);
        const float t = hit.hit ? std::min(std::max(hit.t, 0.0f), params.cutoff) : params.cutoff;
        sum += t / params.cutoff;
      }
      values[tri] = float(sum / k);
    }
    progress.advance(r.size());
  });
  return values;
}

std::vector<uint8_t> estimate_visibility(const Scene& scene, const EmbreeScene& embree,
                                         const Camera& camera, uint32_t width, uint32_t height) {
  std::vector<std::atomic<uint8_t>> seen(scene.triangle_count());
  for (auto& s : seen) s.store(0, std::memory_order_relaxed);
  tbb::parallel_for(uint32_t(0), height, [&](uint32_t y) {
    for (uint32_t x = 0; x < width; ++x) {
      const Camera::Ray ray = camera.primary_ray(x, y, width, height);
      const EmbreeHit hit = embree.intersect(ray.origin, ray.direction, 0.0f,
                                             std::numeric_limits<float>::infinity());
      if (hit.hit && hit.prim < seen.size()) seen[hit.prim].store(1, std::memory_order_relaxed);
    }
  });
  std::vector<uint8_t> visible(seen.size());
  for (size_t i = 0; i < seen.size(); ++i) visible[i] = seen[i].load(std::memory_order_relaxed);
  return visible;
}

std::vector<float> occlusion_weights(const std::vector<float>& values, float floor,
                                     uint64_t* sanitised, bool normalise) {
  uint64_t replaced = 0;
  floor = std::isfinite(floor) ? std::min(std::max(floor, 0.0f), 1.0f) : 0.0f;
  std::vector<float> weights(values.size());
  double sum = 0;
  for (size_t i = 0; i < values.size(); ++i) {
    float v = values[i];
    if (!std::isfinite(v)) {
      v = 1.0f;
      ++replaced;
    } else if (v < 0.0f || v > 1.0f) {
      v = std::min(std::max(v, 0.0f), 1.0f);
      ++replaced;
    }
    weights[i] = floor + (1.0f - floor) * v;
    sum += weights[i];
  }
  if (sanitised) *sanitised = replaced;
  // With floor 0 and every value 0 there is nothing to rank: all weights 1.
  if (!(sum > 0)) {
    std::fill(weights.begin(), weights.end(), 1.0f);
    return weights;
  }
  if (!normalise) return weights;
  // The mean is exact for equal weights (N copies of w sum exactly in double), so
  // w / mean is exactly 1.0f: equal occlusion values give exactly the SAH tree.
  const float mean = float(sum / double(values.size()));
  for (float& w : weights) w = w / mean;
  return weights;
}

}  // namespace rtsim
