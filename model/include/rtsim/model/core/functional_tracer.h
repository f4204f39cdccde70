#pragma once
// The functional level: traces ray batches with the core in parallel (TBB) and
// runs whole frames (primary rays, then the secondary waves the scene calls for),
// with results that are identical whatever the thread count.
#include <rtsim/model/core/ray_generation.h>
#include <rtsim/model/core/traversal.h>
#include <rtsim/workloads/image.h>

#include <array>
#include <cstdint>
#include <vector>

namespace rtsim {

struct TraceResult {
  HitRecord hit;
  RayCounters counters;
};

// Sums of per-ray counters.
struct CounterTotals {
  uint64_t rays = 0, hits = 0;
  uint64_t trv_ops = 0, box_tests = 0, ist_ops = 0, ist_exact_steps = 0;
  uint64_t node_fetches = 0, prim_ref_fetches = 0, triangle_fetches = 0;
  uint64_t node_bytes = 0, prim_ref_bytes = 0, triangle_bytes = 0;
  uint64_t stack_overflows = 0, stack_refills = 0;
  uint64_t anyhit_tests = 0, anyhit_rejects = 0, uv_bytes = 0, texel_bytes = 0;  // alpha testing
  // Two-level trees (RayCounters): the TLAS's share of TRV, and the transforms.
  uint64_t tlas_trv_ops = 0, tlas_node_fetches = 0, tlas_node_bytes = 0, xfm_ops = 0, instance_bytes = 0;
  uint32_t max_stack_depth = 0;
  uint64_t ops() const { return trv_ops + ist_ops; }
  uint64_t bytes() const {
    return node_bytes + prim_ref_bytes + triangle_bytes + uv_bytes + texel_bytes + instance_bytes;
  }
  double per_ray(uint64_t value) const { return rays ? double(value) / double(rays) : 0.0; }
  void add(const RayCounters& c, bool hit);
  void add(const CounterTotals& o);
};

// Traces rays[i] into results[i] (resized). threads = 0: all cores. When `sink`
// is given, every access reaches it in ray order (rays traced in parallel in
// chunks, their accesses recorded and replayed), so cache statistics are
// deterministic too.
void trace_rays(const TraversalContext& context, const std::vector<Ray>& rays,
                std::vector<TraceResult>& results, AccessSink* sink = nullptr,
                uint32_t threads = 0);

// One frame: primary rays, then waves of secondary rays until none are left.
struct FrameRun {
  EffectPlan plan;
  uint32_t width = 0, height = 0, spp = 1;  // image the rays' pixel ids refer to
  std::vector<Ray> rays;            // every ray of every wave; parent indexes into this
  std::vector<TraceResult> results;  // results[i] for rays[i]
  std::array<CounterTotals, kRayTypeCount> per_type{};
  CounterTotals total;
  uint32_t waves = 0;
  double trace_seconds = 0.0;  // host time in trace_rays
};
FrameRun run_frame(const TraversalContext& context, const Camera& camera,
                   const EffectSettings& settings, AccessSink* sink = nullptr, uint32_t threads = 0);
// Replays a given ray set (e.g. from a ray file): no secondary rays are spawned.
FrameRun run_rays(const TraversalContext& context, std::vector<Ray> rays, uint32_t width,
                  uint32_t height, AccessSink* sink = nullptr, uint32_t threads = 0);

// Pictures of a frame (run.width x run.height).
// TRV + IST ops of every ray (all types) credited to its pixel, averaged over samples.
std::vector<float> ops_per_pixel(const FrameRun& run);
// The same for instance transforms (XFM ops): where the TLAS's overlap sends rays
// into several instances.
std::vector<float> xfm_per_pixel(const FrameRun& run);
// Fraction of AO rays that escaped (white = open); pixels without AO rays black.
Image ao_image(const FrameRun& run);
// Albedo x (ambient x AO + direct light with shadows) + mirror/refraction
// contributions; a simple picture to check what was traced.
Image shaded_image(const Scene& scene, const FrameRun& run);

}  // namespace rtsim
