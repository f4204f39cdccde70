#include <rtsim/builder/ray_samples.h>
#include <rtsim/workloads/random.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

namespace rtsim {

namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();

float safe_inverse(float d) {
  // A zero component would give inf and then 0 * inf = NaN on a slab plane.
  const float tiny = 1e-30f;
  if (std::fabs(d) < tiny) d = std::copysign(tiny, d);
  return 1.0f / d;
}


// `count` AO rays from `position` over the hemisphere of `normal` (unit), into slots.
void cast_ao(const EmbreeScene& embree, const vec3& position, const vec3& normal, float offset,
             float cutoff, uint64_t seed, uint64_t key0, uint64_t key1, uint64_t key2, CastRay* slots,
             uint32_t count) {
  const vec3 origin = position + offset * normal;
  for (uint32_t s = 0; s < count; ++s) {
    KeyedRng rng(seed, {key0, key1, key2, s});
    const float r1 = rng.next_float(), r2 = rng.next_float();
    const vec3 dir = cosine_hemisphere_direction(normal, r1, r2);
    const EmbreeHit h = embree.intersect(origin, dir, 0.0f, cutoff);
    CastRay& a = slots[s];
    a.origin = origin;
    a.direction = dir;
    a.t_end = h.hit ? std::min(h.t, cutoff) : cutoff;
    a.hit = h.hit ? h.prim : ~0u;
    a.used = true;
  }
}

// The view-independent set: AO rays from points spread over the surface by area.
RaySamples surface_rays(const Scene& scene, const EmbreeScene& embree, const RaySampleParams& params,
                        uint32_t k, float offset) {
  RaySamples out;
  const size_t points = size_t(params.resolution) * params.resolution;
  // Cumulative triangle areas, summed serially: the same points for any thread count.
  std::vector<double> cumulative(scene.triangle_count());
  double total = 0;
  for (uint32_t t = 0; t < scene.triangle_count(); ++t) {
    const vec3 v0 = scene.vertex(t, 0), v1 = scene.vertex(t, 1), v2 = scene.vertex(t, 2);
    const double a = 0.5 * double(glm::length(glm::cross(v1 - v0, v2 - v0)));
    total += std::isfinite(a) ? a : 0.0;
    cumulative[t] = total;
  }
  if (!(total > 0) || k == 0) return out;
  std::vector<CastRay> ao(points * k);
  tbb::parallel_for(size_t(0), points, [&](size_t point) {
    KeyedRng rng(params.seed, {0x53555246ull, point});
    const double pick = double(rng.next_float()) * total;
    const uint32_t tri = uint32_t(std::min<size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin(), cumulative.size() - 1));
    float u = rng.next_float(), v = rng.next_float();
    if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;  // uniform over the triangle
    const vec3 v0 = scene.vertex(tri, 0), v1 = scene.vertex(tri, 1), v2 = scene.vertex(tri, 2);
    vec3 normal = glm::normalize(glm::cross(v1 - v0, v2 - v0));
    if (rng.next_float() < 0.5f) normal = -normal;
    if (!std::isfinite(normal.x + normal.y + normal.z)) return;  // a sliver: no AO rays
    cast_ao(embree, (1.0f - u - v) * v0 + u * v1 + v * v2, normal, offset, params.ao_cutoff, params.seed,
            0x53555246ull, point, 1, &ao[point * k], k);
  });
  for (const CastRay& s : ao)
    if (s.used) out.push(s.origin, s.direction, s.t_end);
  return out;
}
}  // namespace

void RaySamples::push(const vec3& origin, const vec3& direction, float t_end) {
  ox.push_back(origin.x);
  oy.push_back(origin.y);
  oz.push_back(origin.z);
  ix.push_back(safe_inverse(direction.x));
  iy.push_back(safe_inverse(direction.y));
  iz.push_back(safe_inverse(direction.z));
  tmax.push_back(t_end);
}

CameraRays cast_camera_rays(const Scene& scene, const EmbreeScene& embree,
                            const std::vector<const Camera*>& cameras, uint32_t width, uint32_t height,
                            uint32_t ao_rays, float ao_cutoff, uint64_t seed) {
  CameraRays out;
  const size_t per_camera = size_t(width) * height;
  const uint32_t k = (ao_cutoff > 0 && std::isfinite(ao_cutoff)) ? ao_rays : 0;
  out.ao_per_pixel = k;
  const float offset = 1e-5f * std::max(scene.diagonal(), 1e-30f);
  out.primary.resize(cameras.size() * per_camera);
  out.ao.resize(cameras.size() * per_camera * k);
  tbb::parallel_for(size_t(0), cameras.size() * size_t(height), [&](size_t row) {
    const size_t c = row / height;
    const uint32_t y = uint32_t(row % height);
    const Camera& camera = *cameras[c];
    for (uint32_t x = 0; x < width; ++x) {
      const size_t pixel = size_t(y) * width + x;
      const size_t slot = c * per_camera + pixel;
      const Camera::Ray ray = camera.primary_ray(x, y, width, height);
      const EmbreeHit hit = embree.intersect(ray.origin, ray.direction, 0.0f, kInf);
      CastRay& p = out.primary[slot];
      p.origin = ray.origin;
      p.direction = ray.direction;
      p.t_end = hit.hit ? hit.t : kInf;
      p.hit = hit.hit ? hit.prim : ~0u;
      p.used = true;
      if (!hit.hit || k == 0 || hit.prim >= scene.triangle_count()) continue;
      const uint32_t tri = hit.prim;
      const vec3 v0 = scene.vertex(tri, 0), v1 = scene.vertex(tri, 1), v2 = scene.vertex(tri, 2);
      const vec3 position = (1.0f - hit.u - hit.v) * v0 + hit.u * v1 + hit.v * v2;
      vec3 normal = glm::cross(v1 - v0, v2 - v0);
      const float len = glm::length(normal);
      normal = len > 0 && std::isfinite(len) ? normal / len : -ray.direction;
      if (glm::dot(normal, ray.direction) > 0.0f) normal = -normal;  // face the viewer
      cast_ao(embree, position, normal, offset, ao_cutoff, seed, 0x52444841ull, c, pixel, &out.ao[slot * k], k);
    }
  });
  return out;
}

RaySamples sample_rays(const Scene& scene, const EmbreeScene& embree,
                       const std::vector<const Camera*>& cameras, const RaySampleParams& params) {
  const uint32_t k = (params.ao_cutoff > 0 && std::isfinite(params.ao_cutoff)) ? params.ao_rays : 0;
  if (cameras.empty()) {
    const float offset = 1e-5f * std::max(scene.diagonal(), 1e-30f);
    return surface_rays(scene, embree, params, k, offset);
  }
  const CameraRays cast = cast_camera_rays(scene, embree, cameras, params.resolution, params.resolution,
                                           params.ao_rays, params.ao_cutoff, params.seed);
  RaySamples out;
  for (const CastRay& s : cast.primary)
    if (s.used) out.push(s.origin, s.direction, s.t_end);
  out.primary = out.size();
  for (const CastRay& s : cast.ao)
    if (s.used) out.push(s.origin, s.direction, s.t_end);
  return out;
}

double ray_cost(const Bvh& bvh, const RaySamples& rays, float t1, float t2, size_t first,
                size_t count) {
  if (bvh.empty() || first >= rays.size()) return 0;
  const size_t last = count >= rays.size() - first ? rays.size() : first + count;
  if (last <= first) return 0;
  // Per-ray costs in fixed slots, summed in ray order: the same for any thread count.
  std::vector<double> per_ray(last - first, 0.0);
  tbb::parallel_for(tbb::blocked_range<size_t>(first, last, 256), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<uint32_t> stack;
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const uint32_t ray = uint32_t(i);
      if (!rays.hits(ray, bvh.nodes[0].bounds)) continue;
      double cost = 0;
      stack.assign(1, 0u);
      while (!stack.empty()) {
        const BvhNode& n = bvh.nodes[stack.back()];
        stack.pop_back();
        if (n.is_leaf()) {
          cost += double(t2) * n.count;
          continue;
        }
        cost += double(t1) * n.children;
        for (uint32_t c = 0; c < n.children; ++c)
          if (rays.hits(ray, bvh.nodes[n.index + c].bounds)) stack.push_back(n.index + c);
      }
      per_ray[i - first] = cost;
    }
  });
  double total = 0;
  for (double c : per_ray) total += c;
  return total / double(last - first);
}

}  // namespace rtsim
