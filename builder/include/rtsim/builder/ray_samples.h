#pragma once
// Sample rays for the ray-distribution heuristic (rdh builder; Bittner & Havran
// 2009, Feltman, Lee & Fatahalian 2012): the rays the workload will trace,
// approximated at a low resolution and cast with Embree before the build.
//
// Per camera: one primary ray through each pixel centre of a resolution x
// resolution image (closest hit), and from each primary hit `ao_rays`
// cosine-distributed AO rays over the hemisphere facing the viewer, of length
// `ao_cutoff` (the model's AO length, scene.ao_cutoff()). Every ray is stored as a
// segment: it ends at its closest hit (a miss: at infinity for primary rays, at
// the cutoff for AO rays), because a ray costs work only in the nodes its segment
// reaches. Deterministic: the AO directions come from KeyedRng(seed, {camera,
// pixel, k}) and results are written to fixed slots, then compacted in slot order.
//
// Without cameras (view-independent): resolution x resolution points spread over
// the scene's surface by area, each on a side chosen at random (the viewer's side
// is unknown), and `ao_rays` AO rays from each; no primary rays.
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/scene.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace rtsim {

// Structure of arrays: origin, inverse direction (zero components replaced by a
// tiny value so that it stays finite) and the segment end, for slab tests.
struct RaySamples {
  std::vector<float> ox, oy, oz, ix, iy, iz, tmax;
  uint64_t primary = 0;  // the first `primary` rays are primary rays, the rest AO rays
  size_t size() const { return ox.size(); }
  void push(const vec3& origin, const vec3& direction, float t_end);
  // Whether ray i's segment [0, tmax] meets the box (an empty box: never).
  bool hits(uint32_t i, const Aabb& box) const {
    if (box.lo.x > box.hi.x || box.lo.y > box.hi.y || box.lo.z > box.hi.z) return false;
    const float x0 = (box.lo.x - ox[i]) * ix[i], x1 = (box.hi.x - ox[i]) * ix[i];
    const float y0 = (box.lo.y - oy[i]) * iy[i], y1 = (box.hi.y - oy[i]) * iy[i];
    const float z0 = (box.lo.z - oz[i]) * iz[i], z1 = (box.hi.z - oz[i]) * iz[i];
    const float tnear = std::max(std::max(std::min(x0, x1), std::min(y0, y1)),
                                 std::max(std::min(z0, z1), 0.0f));
    const float tfar = std::min(std::min(std::max(x0, x1), std::max(y0, y1)),
                                std::min(std::max(z0, z1), tmax[i]));
    return tnear <= tfar;
  }
};

struct RaySampleParams {
  uint32_t resolution = 64;  // primary rays per side per camera (0 = no rays)
  uint32_t ao_rays = 4;      // AO rays per primary hit
  float ao_cutoff = 1.0f;    // absolute AO ray length
  uint64_t seed = 1;
};

RaySamples sample_rays(const Scene& scene, const EmbreeScene& embree,
                       const std::vector<const Camera*>& cameras, const RaySampleParams& params);

// One cast ray of a camera workload, in a fixed slot.
struct CastRay {
  vec3 origin{0.0f}, direction{0.0f};
  float t_end = 0;   // the closest hit; a miss: infinity (primary) or the cutoff (AO)
  uint32_t hit = ~0u;  // the triangle hit first, ~0u: none
  bool used = false;   // false: an AO slot of a primary ray that hit nothing
};

// The rays of the workload on `cameras`, cast with Embree, as rdh samples them and
// OSAH marks its visible triangles: per camera one primary ray through each pixel
// centre of a width x height image, and `ao_rays` AO rays from each primary hit
// (cosine-distributed over the hemisphere facing the viewer, length ao_cutoff,
// directions from KeyedRng(seed, {camera, pixel, k})). Slots: primary[camera *
// width * height + pixel], ao[(that slot) * ao_per_pixel + k]. No AO rays when
// ao_cutoff is not a positive finite length.
struct CameraRays {
  std::vector<CastRay> primary, ao;
  uint32_t ao_per_pixel = 0;
};
CameraRays cast_camera_rays(const Scene& scene, const EmbreeScene& embree,
                            const std::vector<const Camera*>& cameras, uint32_t width, uint32_t height,
                            uint32_t ao_rays, float ao_cutoff, uint64_t seed);

// The modelled cost of the rays on a tree: per ray, 2 * t1 for every inner node
// and t2 x triangles for every leaf whose box its segment meets (each node is
// tested only if its parent's box is met), averaged over the rays. `first`/`count`
// select a range of rays (default: all).
double ray_cost(const Bvh& bvh, const RaySamples& rays, float t1, float t2, size_t first = 0,
                size_t count = ~size_t(0));

}  // namespace rtsim
