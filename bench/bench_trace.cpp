// One-thread throughput of the functional ray core for primary and AO rays, side
// by side with Embree (rtcIntersect1 / rtcOccluded1) on the same rays.
// Scenes: the default scene, and `dragon` when it has been fetched into the
// scene cache (RTSIM_CACHE). Report: items_per_second = rays/s.
#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/scene_registry.h>

#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

using namespace rtsim;

namespace {

struct Workload {
  Scene scene;
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;
  std::unique_ptr<EmbreeScene> embree;
  std::vector<Ray> primary, ao;

  explicit Workload(const std::string& name) : scene(load_scene(name)) {
    BuildParams params;
    params.builder = "sah";
    bvh = build_bvh(scene, params);
    image = std::make_unique<MemoryImage>(scene, bvh);
    context = std::make_unique<TraversalContext>(scene, bvh, *image);
    embree = std::make_unique<EmbreeScene>(scene);
    EffectSettings settings;
    settings.width = 256;
    settings.height = 256;
    settings.ao_samples = 4;
    const FrameRun run = run_frame(*context, scene.cameras.front(), settings);
    for (const Ray& r : run.rays) (r.type == RayType::Primary ? primary : ao).push_back(r);
    if (ao.empty()) ao = primary;  // a scene with AO off: still measure any-hit rays
  }
};

void core_rays(benchmark::State& state, const Workload* w, bool use_ao) {
  const std::vector<Ray>& rays = use_ao ? w->ao : w->primary;
  RayTraversal traversal(*w->context);
  uint64_t ops = 0, hits = 0;
  for (auto _ : state) {
    for (const Ray& r : rays) {
      hits += trace_ray(traversal, r).hit() ? 1 : 0;
      ops += traversal.counters().ops();
    }
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(int64_t(state.iterations() * rays.size()));
  state.counters["ops_per_ray"] = double(ops) / double(state.iterations() * rays.size());
}

void embree_rays(benchmark::State& state, const Workload* w, bool use_ao) {
  const std::vector<Ray>& rays = use_ao ? w->ao : w->primary;
  uint64_t hits = 0;
  for (auto _ : state) {
    for (const Ray& r : rays) {
      if (use_ao)
        hits += w->embree->occluded(r.origin, r.direction, r.tmin, r.tmax) ? 1 : 0;
      else
        hits += w->embree->intersect(r.origin, r.direction, r.tmin, r.tmax).hit ? 1 : 0;
    }
  }
  benchmark::DoNotOptimize(hits);
  state.SetItemsProcessed(int64_t(state.iterations() * rays.size()));
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::vector<std::string> names{default_scene_name()};
  if (std::filesystem::exists(scene_cache_dir() / "dragon" / "scene.toml")) names.push_back("dragon");
  std::vector<std::unique_ptr<Workload>> workloads;
  for (const std::string& name : names) {
    workloads.push_back(std::make_unique<Workload>(name));
    const Workload* w = workloads.back().get();
    benchmark::RegisterBenchmark(("core_primary/" + name).c_str(), core_rays, w, false)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("embree_intersect1/" + name).c_str(), embree_rays, w, false)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("core_ao/" + name).c_str(), core_rays, w, true)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("embree_occluded1/" + name).c_str(), embree_rays, w, true)->Unit(benchmark::kMillisecond);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
