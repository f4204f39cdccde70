#include <rtsim/builder/occlusion.h>
#include <rtsim/builder/ray_samples.h>
#include <rtsim/workloads/progress.h>
#include <rtsim/workloads/random.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <atomic>
#include <cmath>
#include <limits>

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

namespace {
uint64_t orientation_class(const vec3& n) {
  const float ax = std::fabs(n.x), ay = std::fabs(n.y), az = std::fabs(n.z);
  const uint64_t dominant = ax >= ay && ax >= az ? 0 : ay >= az ? 1 : 2;
  const uint64_t octant = (n.x < 0 ? 1u : 0u) | (n.y < 0 ? 2u : 0u) | (n.z < 0 ? 4u : 0u);
  return dominant * 8 + octant;
}

struct TriangleFrame {
  vec3 v0, v1, v2, normal, tangent, bitangent;
};

bool triangle_frame(const Scene& scene, uint32_t tri, TriangleFrame* f) {
  f->v0 = scene.vertex(tri, 0), f->v1 = scene.vertex(tri, 1), f->v2 = scene.vertex(tri, 2);
  const vec3 cross = glm::cross(f->v1 - f->v0, f->v2 - f->v0);
  const float len = glm::length(cross);
  if (!(len > 0) || !std::isfinite(len)) return false;  // zero area: value 1 (see header)
  f->normal = cross / len;
  frame(f->normal, &f->tangent, &f->bitangent);
  return true;
}

// Sorts 64-bit words by their upper 32 bits, keeping words with equal upper bits
// in their given order (LSD radix sort, three passes of 11 bits).
void sort_by_upper_half(std::vector<uint64_t>* words) {
  std::vector<uint64_t> scratch(words->size());
  for (int shift = 32; shift < 64; shift += 11) {
    std::vector<size_t> offset(2049, 0);
    for (uint64_t w : *words) ++offset[((w >> shift) & 2047) + 1];
    for (size_t d = 1; d < offset.size(); ++d) offset[d] += offset[d - 1];
    for (uint64_t w : *words) scratch[offset[(w >> shift) & 2047]++] = w;
    words->swap(scratch);
  }
}

// The groups of triangles that share one estimate: sorted by (orientation, Morton
// code of the centroid on a 512^3 grid, triangle id), cut wherever the orientation
// or the cell of side at most kCellOfCutoff x cutoff changes (cells no finer than
// the grid, which a cutoff of a fiftieth of the scene's extent reaches), and each run
// cut into near-equal groups of at most `share`. Returns the triangles in that
// order and the group starts (plus the end).
constexpr float kCellOfCutoff = 0.25f;
void share_groups(const Scene& scene, uint32_t share, float cutoff, std::vector<uint32_t>* order,
                  std::vector<uint32_t>* starts) {
  const size_t n = scene.triangle_count();
  struct Box {
    vec3 lo{std::numeric_limits<float>::max()}, hi{-std::numeric_limits<float>::max()};
  };
  const Box box = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 4096), Box{},
      [&](const tbb::blocked_range<size_t>& r, Box b) {
        for (size_t t = r.begin(); t != r.end(); ++t)
          for (int c = 0; c < 3; ++c) {
            b.lo = glm::min(b.lo, scene.vertex(uint32_t(t), c));
            b.hi = glm::max(b.hi, scene.vertex(uint32_t(t), c));
          }
        return b;
      },
      [](Box x, const Box& y) {
        x.lo = glm::min(x.lo, y.lo);
        x.hi = glm::max(x.hi, y.hi);
        return x;
      });
  const float extent = std::max(std::max(box.hi.x - box.lo.x, box.hi.y - box.lo.y),
                                std::max(box.hi.z - box.lo.z, 1e-30f));
  constexpr int kAxisBits = 9;  // 5 orientation bits + 27 Morton bits: the upper half
  const float cells = float(1u << kAxisBits);
  int level = 0;  // the coarsest grid whose cells are no wider than kCellOfCutoff x cutoff
  while (level < kAxisBits && extent / float(1u << level) > kCellOfCutoff * cutoff) ++level;
  const int cell_shift = 32 + 3 * (kAxisBits - level);
  // Zero-area triangles get an orientation class past the 24 real ones: they sort
  // last and are dropped.
  constexpr uint64_t kNoClass = 31;
  std::vector<uint64_t> keys(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      // One pass over the triangles: validity (triangle_frame's test), orientation, cell.
      const uint32_t tri = uint32_t(t);
      const vec3 v0 = scene.vertex(tri, 0), v1 = scene.vertex(tri, 1), v2 = scene.vertex(tri, 2);
      const vec3 cross = glm::cross(v1 - v0, v2 - v0);
      const float len = glm::length(cross);
      if (!(len > 0) || !std::isfinite(len)) {
        keys[t] = kNoClass << 59 | t;
        continue;
      }
      const vec3 p = ((v0 + v1 + v2) / 3.0f - box.lo) / extent * cells;
      uint64_t m = 0;
      for (int a = 0; a < 3; ++a)
        m |= spread_bits_21(uint64_t(std::min(std::max(p[a], 0.0f), cells - 1.0f))) << a;
      keys[t] = (orientation_class(cross) << 27 | m) << 32 | t;
    }
  });
  sort_by_upper_half(&keys);  // ties keep id order
  while (!keys.empty() && (keys.back() >> 59) == kNoClass) keys.pop_back();
  order->resize(keys.size());
  for (size_t i = 0; i < keys.size(); ++i) (*order)[i] = uint32_t(keys[i]);
  starts->clear();
  for (size_t run = 0, i = 1; run < keys.size(); ++i) {
    if (i < keys.size() && (keys[i] >> cell_shift) == (keys[run] >> cell_shift)) continue;
    // keys[run, i) is one cell of one orientation: cut it into ceil(len / share) pieces.
    const size_t len = i - run, pieces = (len + share - 1) / share;
    for (size_t p = 0; p < pieces; ++p) starts->push_back(uint32_t(run + p * len / pieces));
    run = i;
  }
  starts->push_back(uint32_t(keys.size()));
}
}  // namespace

std::vector<float> estimate_occlusion(const Scene& scene, const EmbreeScene& embree,
                                      const OcclusionParams& params, uint64_t* rays_cast) {
  const size_t n = scene.triangle_count();
  std::vector<float> values(n, 1.0f);
  if (rays_cast) *rays_cast = 0;
  if (params.rays == 0 || !(params.cutoff > 0) || n == 0) return values;
  const uint32_t k = params.rays;
  // Lift the origin off the surface so a ray cannot hit its own triangle.
  const float offset = 1e-5f * std::max(scene.diagonal(), 1e-30f);
  std::vector<uint32_t> order, starts;
  if (params.share <= 1) {
    std::vector<uint8_t> valid(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
      TriangleFrame f;
      for (size_t t = r.begin(); t != r.end(); ++t) valid[t] = triangle_frame(scene, uint32_t(t), &f);
    });
    for (size_t t = 0; t < n; ++t)
      if (valid[t]) order.push_back(uint32_t(t));
    starts.resize(order.size() + 1);
    for (size_t i = 0; i < starts.size(); ++i) starts[i] = uint32_t(i);
  } else {
    share_groups(scene, params.share, params.cutoff, &order, &starts);
  }
  const size_t groups = starts.size() - 1;

  // The mean over one ray's clamp(t, 0, cutoff) / cutoff. Ray `local` of `count` from
  // triangle f: a stratified point on it, a cosine-weighted direction on the given side.
  // Keyed by the triangle's vertices, not its index: the same geometry draws the
  // same rays in any face order.
  auto cast = [&](uint64_t tri_key, const TriangleFrame& f, uint32_t local, uint32_t count, float side) {
    const uint32_t grid_x = std::max<uint32_t>(1, uint32_t(std::ceil(std::sqrt(double(count)))));
    const uint32_t grid_y = (count + grid_x - 1) / grid_x;
    KeyedRng rng(params.seed, {0xA0A0ull, tri_key, local});
    const float u1 = (float(local % grid_x) + rng.next_float()) / float(grid_x);
    const float u2 = (float((local / grid_x) % grid_y) + rng.next_float()) / float(grid_y);
    const float su = std::sqrt(u1);
    const vec3 point = (1.0f - su) * f.v0 + su * (1.0f - u2) * f.v1 + su * u2 * f.v2;
    // Cosine-weighted direction (Malley: uniform disc lifted to the hemisphere).
    const float r1 = rng.next_float(), r2 = rng.next_float();
    const float radius = std::sqrt(r1), phi = 6.28318530718f * r2;
    const vec3 local_dir(radius * std::cos(phi), radius * std::sin(phi), std::sqrt(std::max(0.0f, 1.0f - r1)));
    const vec3 dir = glm::normalize(local_dir.x * f.tangent + local_dir.y * f.bitangent + side * local_dir.z * f.normal);
    const EmbreeHit hit = embree.intersect(point + side * offset * f.normal, dir, 0.0f, params.cutoff);
    const float t = hit.hit ? std::min(std::max(hit.t, 0.0f), params.cutoff) : params.cutoff;
    return t / params.cutoff;
  };

  std::vector<float> group_values(groups);
  std::atomic<uint64_t> total_rays{0};
  Progress progress("AO rays", order.size(), "triangles");
  tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 64), [&](const tbb::blocked_range<size_t>& r) {
    uint64_t cast_here = 0;
    size_t triangles_here = 0;
    for (size_t g = r.begin(); g != r.end(); ++g) {
      const uint32_t first = starts[g], m = starts[g + 1] - first;
      // The group's K rays: with m <= K members, member j casts rays j, j + m, ...
      // (local indices 0, 1, ..., so a group of one is exactly the per-triangle
      // estimate); with more members than rays, ray s comes from member s * m / K, spread
      // evenly along the group's Morton order.
      double sum = 0;
      TriangleFrame f;
      for (uint32_t j = 0; j < std::min(m, k); ++j) {
        const uint32_t member = m <= k ? j : uint32_t(uint64_t(j) * m / k);
        const uint32_t tri = order[first + member];
        triangle_frame(scene, tri, &f);
        const uint64_t tri_key = triangle_geometry_key(scene, tri);
        const uint32_t count = m <= k ? (k - j + m - 1) / m : 1;
        for (uint32_t local = 0; local < count; ++local) {
          const uint32_t ray = m <= k ? j + local * m : j;
          const float side = (params.both_sides && (ray & 1u)) ? -1.0f : 1.0f;
          sum += cast(tri_key, f, local, count, side);
        }
      }
      group_values[g] = float(sum / k);
      cast_here += k;
      triangles_here += m;
    }
    total_rays += cast_here;
    progress.advance(triangles_here);
  });
  tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t g = r.begin(); g != r.end(); ++g)
      for (uint32_t i = starts[g]; i < starts[g + 1]; ++i) values[order[i]] = group_values[g];
  });
  if (rays_cast) *rays_cast = total_rays.load();
  return values;
}

std::vector<uint8_t> estimate_visibility(const Scene& scene, const EmbreeScene& embree, const Camera& camera,
                                         const VisibilityParams& params) {
  const CameraRays rays = cast_camera_rays(scene, embree, {&camera}, params.width, params.height,
                                           params.ao_rays, params.ao_cutoff, params.seed);
  std::vector<uint8_t> visible(scene.triangle_count(), 0);
  for (const std::vector<CastRay>* kind : {&rays.primary, &rays.ao})
    for (const CastRay& ray : *kind)
      if (ray.used && ray.hit < visible.size()) visible[ray.hit] = 1;
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
