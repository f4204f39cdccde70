#include <rtsim/model/core/functional_tracer.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace rtsim {

void CounterTotals::add(const RayCounters& c, bool hit) {
  ++rays;
  hits += hit ? 1 : 0;
  trv_ops += c.trv_ops;
  box_tests += c.box_tests;
  ist_ops += c.ist_ops;
  ist_exact_steps += c.ist_exact_steps;
  node_fetches += c.node_fetches;
  prim_ref_fetches += c.prim_ref_fetches;
  triangle_fetches += c.triangle_fetches;
  node_bytes += c.node_bytes;
  prim_ref_bytes += c.prim_ref_bytes;
  triangle_bytes += c.triangle_bytes;
  stack_overflows += c.stack_overflows;
  stack_refills += c.stack_refills;
  anyhit_tests += c.anyhit_tests, anyhit_rejects += c.anyhit_rejects;
  uv_bytes += c.uv_bytes, texel_bytes += c.texel_bytes;
  tlas_trv_ops += c.tlas_trv_ops, tlas_node_fetches += c.tlas_node_fetches, tlas_node_bytes += c.tlas_node_bytes;
  xfm_ops += c.xfm_ops, instance_bytes += c.instance_bytes;
  max_stack_depth = std::max(max_stack_depth, c.max_stack_depth);
}

void CounterTotals::add(const CounterTotals& o) {
  rays += o.rays;
  hits += o.hits;
  trv_ops += o.trv_ops;
  box_tests += o.box_tests;
  ist_ops += o.ist_ops;
  ist_exact_steps += o.ist_exact_steps;
  node_fetches += o.node_fetches;
  prim_ref_fetches += o.prim_ref_fetches;
  triangle_fetches += o.triangle_fetches;
  node_bytes += o.node_bytes;
  prim_ref_bytes += o.prim_ref_bytes;
  triangle_bytes += o.triangle_bytes;
  stack_overflows += o.stack_overflows;
  stack_refills += o.stack_refills;
  anyhit_tests += o.anyhit_tests, anyhit_rejects += o.anyhit_rejects;
  uv_bytes += o.uv_bytes, texel_bytes += o.texel_bytes;
  tlas_trv_ops += o.tlas_trv_ops, tlas_node_fetches += o.tlas_node_fetches, tlas_node_bytes += o.tlas_node_bytes;
  xfm_ops += o.xfm_ops, instance_bytes += o.instance_bytes;
  max_stack_depth = std::max(max_stack_depth, o.max_stack_depth);
}

namespace {

constexpr size_t kChunkRays = 256;       // rays per parallel task
constexpr size_t kReplayBatch = 1 << 14;  // rays whose fetches are buffered before replay

// Records accesses in order; a zero-byte entry marks the end of a step.
struct RecordingSink : AccessSink {
  std::vector<std::pair<MemoryAccess, RayType>> fetches;
  void on_access(const MemoryAccess& a, RayType t) override { fetches.emplace_back(a, t); }
  void on_step_end() override { fetches.emplace_back(MemoryAccess{}, RayType::Primary); }
};

void trace_range(const TraversalContext& context, const Ray* rays, size_t count, TraceResult* out,
                 AccessSink* sink) {
  if (!sink) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, kChunkRays),
                      [&](const tbb::blocked_range<size_t>& r) {
                        RayTraversal traversal(context);
                        for (size_t i = r.begin(); i < r.end(); ++i) {
                          out[i].hit = trace_ray(traversal, rays[i]);
                          out[i].counters = traversal.counters();
                        }
                      });
    return;
  }
  // Fetch order must not depend on scheduling: trace chunks in parallel into
  // per-chunk buffers, then hand the buffers to the sink in ray order.
  std::vector<RecordingSink> chunks;
  for (size_t batch = 0; batch < count; batch += kReplayBatch) {
    const size_t batch_count = std::min(kReplayBatch, count - batch);
    const size_t chunk_count = (batch_count + kChunkRays - 1) / kChunkRays;
    chunks.resize(chunk_count);
    tbb::parallel_for(size_t(0), chunk_count, [&](size_t c) {
      RayTraversal traversal(context);
      chunks[c].fetches.clear();
      const size_t begin = batch + c * kChunkRays, end = std::min(begin + kChunkRays, batch + batch_count);
      for (size_t i = begin; i < end; ++i) {
        out[i].hit = trace_ray(traversal, rays[i], &chunks[c]);
        out[i].counters = traversal.counters();
      }
    });
    for (size_t c = 0; c < chunk_count; ++c)
      for (const auto& [a, t] : chunks[c].fetches) {
        if (a.bytes == 0) sink->on_step_end();
        else sink->on_access(a, t);
      }
  }
}

template <class F>
void in_arena(uint32_t threads, F&& f) {
  if (threads == 0) {
    f();
  } else {
    tbb::task_arena arena{int(threads)};
    arena.execute(f);
  }
}

void tally(FrameRun& run) {
  run.per_type = {};
  run.total = CounterTotals{};
  for (size_t i = 0; i < run.rays.size(); ++i)
    run.per_type[ray_type_index(run.rays[i].type)].add(run.results[i].counters, run.results[i].hit.hit());
  for (const CounterTotals& t : run.per_type) run.total.add(t);
}

}  // namespace

void trace_rays(const TraversalContext& context, const std::vector<Ray>& rays,
                std::vector<TraceResult>& results, AccessSink* sink, uint32_t threads) {
  results.resize(rays.size());
  in_arena(threads, [&] { trace_range(context, rays.data(), rays.size(), results.data(), sink); });
}

FrameRun run_frame(const TraversalContext& context, const Camera& camera,
                   const EffectSettings& settings, AccessSink* sink, uint32_t threads) {
  const Scene& scene = context.scene();
  FrameRun run;
  run.plan = plan_effects(scene, settings);
  run.width = settings.width;
  run.height = settings.height;
  run.spp = settings.spp;
  run.rays = generate_primary_rays(camera, settings);
  size_t wave_begin = 0;
  in_arena(threads, [&] {
    while (wave_begin < run.rays.size()) {
      const size_t wave_end = run.rays.size();
      run.results.resize(wave_end);
      const auto start = std::chrono::steady_clock::now();
      trace_range(context, run.rays.data() + wave_begin, wave_end - wave_begin,
                  run.results.data() + wave_begin, sink);
      run.trace_seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      ++run.waves;
      // Secondary rays of this wave, in ray order (chunks spawn in parallel, joined in order).
      const size_t count = wave_end - wave_begin;
      const size_t chunk_count = (count + kChunkRays - 1) / kChunkRays;
      std::vector<std::vector<Ray>> spawned(chunk_count);
      tbb::parallel_for(size_t(0), chunk_count, [&](size_t c) {
        const size_t begin = wave_begin + c * kChunkRays, end = std::min(begin + kChunkRays, wave_end);
        for (size_t i = begin; i < end; ++i)
          spawn_secondary_rays(scene, run.plan, settings, run.rays[i], uint32_t(i),
                               run.results[i].hit, spawned[c]);
      });
      for (const auto& s : spawned) run.rays.insert(run.rays.end(), s.begin(), s.end());
      wave_begin = wave_end;
    }
  });
  tally(run);
  return run;
}

FrameRun run_rays(const TraversalContext& context, std::vector<Ray> rays, uint32_t width,
                  uint32_t height, AccessSink* sink, uint32_t threads) {
  FrameRun run;
  run.width = width;
  run.height = height;
  run.spp = 1;
  run.rays = std::move(rays);
  for (RayType t : kAllRayTypes) run.plan.reason[ray_type_index(t)] = "replayed from a ray set";
  for (const Ray& r : run.rays) {
    run.plan.enabled[ray_type_index(r.type)] = true;
    run.spp = std::max(run.spp, r.sample + 1);
  }
  const auto start = std::chrono::steady_clock::now();
  trace_rays(context, run.rays, run.results, sink, threads);
  run.trace_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.waves = 1;
  tally(run);
  return run;
}

namespace {
// A count of every ray credited to its pixel, averaged over the samples.
template <class Count>
std::vector<float> per_pixel(const FrameRun& run, Count count) {
  std::vector<float> out(size_t(run.width) * run.height, 0.0f);
  for (size_t i = 0; i < run.rays.size(); ++i)
    if (run.rays[i].pixel < out.size()) out[run.rays[i].pixel] += float(count(run.results[i].counters));
  for (float& v : out) v /= float(std::max(run.spp, 1u));
  return out;
}
}  // namespace

std::vector<float> ops_per_pixel(const FrameRun& run) {
  return per_pixel(run, [](const RayCounters& c) { return c.ops(); });
}

std::vector<float> xfm_per_pixel(const FrameRun& run) {
  return per_pixel(run, [](const RayCounters& c) { return c.xfm_ops; });
}

Image ao_image(const FrameRun& run) {
  Image image(run.width, run.height);
  std::vector<uint32_t> open(image.pixels.size(), 0), total(image.pixels.size(), 0);
  for (size_t i = 0; i < run.rays.size(); ++i) {
    const Ray& r = run.rays[i];
    if (r.type != RayType::Ao || r.pixel >= total.size()) continue;
    ++total[r.pixel];
    if (!run.results[i].hit.hit()) ++open[r.pixel];
  }
  for (size_t p = 0; p < total.size(); ++p)
    if (total[p]) image.pixels[p] = vec3(float(open[p]) / float(total[p]));
  return image;
}

Image shaded_image(const Scene& scene, const FrameRun& run) {
  // Children always come after their parent, so one backward pass gathers every
  // child's contribution before its parent is shaded.
  struct Gather {
    uint32_t ao_open = 0, ao_total = 0, lights_visible = 0, lights_tested = 0;
    float direct = 0.0f;
    vec3 reflected{0.0f}, refracted{0.0f}, diffuse{0.0f};
  };
  const vec3 background(0.05f, 0.05f, 0.08f);
  std::vector<Gather> gather(run.rays.size());
  Image image(run.width, run.height);
  const float light_count = float(std::max<size_t>(scene.lights.size(), 1));
  for (size_t i = run.rays.size(); i-- > 0;) {
    const Ray& r = run.rays[i];
    const HitRecord& hit = run.results[i].hit;
    Gather* parent = r.parent < i ? &gather[r.parent] : nullptr;
    if (r.type == RayType::Ao) {
      if (parent) ++parent->ao_total, parent->ao_open += hit.hit() ? 0 : 1;
      continue;
    }
    if (r.type == RayType::Shadow) {
      // A replayed ray file may hold a shadow ray whose parent missed (rays edited,
      // or made for other bounds): it lights nothing, and the parent has no surface.
      if (parent && !hit.hit() && run.results[r.parent].hit.hit()) {
        const SurfaceHit s = surface_at(scene, run.rays[r.parent], run.results[r.parent].hit);
        parent->direct += std::max(0.0f, glm::dot(glm::normalize(r.direction), s.normal)) / light_count;
      }
      continue;
    }
    vec3 colour = background;
    if (hit.hit()) {
      const SurfaceHit s = surface_at(scene, r, hit);
      const Gather& g = gather[i];
      const float ao = g.ao_total ? float(g.ao_open) / float(g.ao_total) : 1.0f;
      const vec3 albedo = albedo_of(s.material);
      float light;
      if (run.plan.on(RayType::Shadow)) {
        light = 0.15f * ao + 0.85f * g.direct;
      } else {
        const float facing = std::fabs(glm::dot(glm::normalize(r.direction), s.normal));
        light = ao * (0.25f + 0.75f * facing);
      }
      colour = albedo * light;
      if (s.material) {
        const float refl = std::clamp(s.material->reflectance, 0.0f, 1.0f);
        const float trans = std::clamp(s.material->transmittance, 0.0f, 1.0f - refl);
        const bool has_refl = run.plan.on(RayType::Reflection) && r.bounce < run.plan.max_depth;
        const bool has_trans = run.plan.on(RayType::Refraction) && r.bounce < run.plan.max_depth;
        const float kept = 1.0f - (has_refl ? refl : 0.0f) - (has_trans ? trans : 0.0f);
        colour = colour * kept + (has_refl ? refl * g.reflected : vec3(0.0f)) +
                 (has_trans ? trans * g.refracted : vec3(0.0f)) + s.material->emission;
      }
      // A cosine-weighted bounce's pdf cancels the cosine and 1/pi of a Lambertian
      // surface: the light it brings back counts albedo times what it found (divided
      // by its chance to survive where russian roulette could have ended it).
      const bool roulette = run.plan.russian_roulette && diffuse_depth(r.type) >= 1;
      colour += albedo * g.diffuse / (roulette ? roulette_keep_probability(albedo) : 1.0f);
    }
    if (r.type == RayType::Primary) {
      if (r.pixel < image.pixels.size())
        image.pixels[r.pixel] += glm::clamp(colour, vec3(0.0f), vec3(1.0f)) / float(std::max(run.spp, 1u));
    } else if (parent) {
      if (diffuse_depth(r.type) > 0) parent->diffuse = colour;
      else (r.type == RayType::Reflection ? parent->reflected : parent->refracted) = colour;
    }
  }
  return image;
}

}  // namespace rtsim
