#pragma once
// Per-triangle estimates the weighted builders use, cast with Embree.
//
// Occlusion value (AO-BVH, the patent's "occlusion information"): the mean over K
// AO rays of clamp(t, 0, cutoff) / cutoff, t the closest hit (a miss counts as the
// cutoff, i.e. 1). Rays start at stratified points on the triangle and are
// cosine-distributed over the hemisphere on its front side (the side its winding
// normal (v1-v0)x(v2-v0) points to); with both_sides, even-numbered rays use the
// front and odd-numbered rays the back. 1 = fully open, near 0 = heavily occluded.
// A zero-area triangle has no side to shoot from: its value is 1 (no information,
// so it keeps the plain SAH weight).
//
// Shared estimates (share > 1): nearby triangles facing the same way pool their rays.
// Triangles are grouped by orientation (24 classes, within about 55 degrees) and by
// a grid cell no wider than a quarter of the cutoff, and each such run, in Morton
// order, is cut into near-equal groups of at most `share`. A group casts K rays in
// all, spread over its members, and each member gets the group's mean. K then counts
// rays per group, not per triangle: about K / share rays per triangle where the
// mesh is dense, up to K where it is sparse. share = 1 is the patent's per-triangle
// estimate exactly (the same rays, the same values). docs/build-speed.md measures
// what sharing costs in tree quality.
//
// Visibility (OSAH), as Vinkler, Havran and Sochor's renderer marks it (NTrace's
// Renderer and CudaBVH::trace): a triangle is visible if a primary ray of the camera
// (one through each pixel centre of a width x height image) hits it first, or, when
// the workload has AO, one of the AO rays cast from those hits does
// (cast_camera_rays, the rays rdh samples too).
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/scene.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace rtsim {

struct OcclusionParams {
  uint32_t rays = 16;         // K per estimate (per triangle when share = 1)
  uint32_t share = 1;         // at most this many triangles share one estimate
  float cutoff = 1.0f;        // absolute AO ray length
  bool both_sides = false;
  uint64_t seed = 1;
};

// Deterministic: a triangle's rays are keyed by its vertices (triangle_geometry_key)
// and the seed, never by its index or the thread count; within a shared group,
// triangles of one orientation class and grid cell are taken in index order, which
// build_bvh makes the geometric order. *rays_cast: the AO rays cast.
std::vector<float> estimate_occlusion(const Scene& scene, const EmbreeScene& embree,
                                      const OcclusionParams& params, uint64_t* rays_cast = nullptr);

struct VisibilityParams {
  uint32_t width = 256, height = 256;  // primary rays through the pixel centres
  uint32_t ao_rays = 4;                // AO rays per primary hit that also mark (0: primary only)
  float ao_cutoff = 0;                 // absolute AO length (<= 0: no AO rays)
  uint64_t seed = 1;                   // the AO directions
};
std::vector<uint8_t> estimate_visibility(const Scene& scene, const EmbreeScene& embree, const Camera& camera,
                                         const VisibilityParams& params);

// AO-BVH weights from occlusion values: w = floor + (1 - floor) * value.
// normalise = true (the default): then scaled to mean 1 so that T2 keeps meaning
// "one average triangle test" and the balance against the 2*T1 node cost is that
// of the plain SAH (equal values give exactly weight 1, hence exactly the SAH tree).
// normalise = false: the weights are used as they are - the patent's literal
// AO(S), a sum of occlusion values in place of the triangle count with the same
// T2; the mean weight is then below 1, so the builder sees triangle tests as
// cheaper (most of all in occluded regions) and makes larger leaves there.
// The floor keeps fully occluded regions from costing nothing (they would
// otherwise be swallowed into huge, arbitrary subtrees and, at value 0
// everywhere, every split would cost the same). With floor 0 and every value 0
// there is nothing to rank: all weights are 1 in both forms.
// NaN / infinite values count as 1 (open); values outside [0, 1] are clamped;
// both are counted in *sanitised.
// An occlusion value as the weights read it: NaN / infinite is open (1), others
// clamped to [0, 1] (what occlusion_weights does before weighing; means use it too).
inline float usable_occlusion(float v) { return std::isfinite(v) ? std::min(std::max(v, 0.0f), 1.0f) : 1.0f; }

std::vector<float> occlusion_weights(const std::vector<float>& values, float floor,
                                     uint64_t* sanitised = nullptr, bool normalise = true);

}  // namespace rtsim
