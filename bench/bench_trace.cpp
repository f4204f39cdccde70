// One-thread throughput of the functional ray core for primary and AO rays, per
// node format (the tree built and collapsed for it), side by side with Embree
// (rtcIntersect1 / rtcOccluded1) on the same rays on its own BVH4 and BVH8
// (tri_accel=bvh4.triangle4 / bvh8.triangle4).
// Scenes: the default scene, and `dragon` when it has been fetched into the
// scene cache (RTSIM_CACHE). Report: items_per_second = rays/s.
// env RTSIM_BENCH_BUILDER=NAME: the builder of our trees (default sah), as in
// bench_simulate; Embree's rows always traverse Embree's own trees, so the ratio
// between the two shows the core and the tree together.
#include "bench_env.h"

#include <rtsim/builder/build.h>
#include <rtsim/builder/memory_image.h>
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/scene_registry.h>

#include <benchmark/benchmark.h>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

using namespace rtsim;

namespace {

const char* const kFormats[] = {"bvh2-64", "bvh4-128", "bvh6-64q", "bvh8-80q"};

struct FormatTree {
  Bvh bvh;
  std::unique_ptr<MemoryImage> image;
  std::unique_ptr<TraversalContext> context;
};

struct Workload {
  Scene scene;
  std::map<std::string, FormatTree> trees;
  std::unique_ptr<EmbreeScene> embree4, embree8;
  std::vector<Ray> primary, ao;

  Workload(const std::string& name, const std::string& builder) : scene(load_scene(name)) {
    for (const char* format : kFormats) {
      BuildParams params;
      params.builder = builder;
      apply_node_format(params, node_format(format));
      FormatTree& t = trees[format];
      t.bvh = build_bvh(scene, params);
      MemoryLayoutConfig layout;
      layout.node_format = format;
      t.image = std::make_unique<MemoryImage>(scene, t.bvh, layout);
      t.context = std::make_unique<TraversalContext>(scene, t.bvh, *t.image);
    }
    embree4 = std::make_unique<EmbreeScene>(scene, "tri_accel=bvh4.triangle4");
    embree8 = std::make_unique<EmbreeScene>(scene, "tri_accel=bvh8.triangle4");
    const TraversalContext& context = *trees.at("bvh2-64").context;
    EffectSettings settings;
    settings.width = 256;
    settings.height = 256;
    settings.ao_samples = 4;
    const FrameRun run = run_frame(context, scene.cameras.front(), settings);
    for (const Ray& r : run.rays) (r.type == RayType::Primary ? primary : ao).push_back(r);
    if (ao.empty()) ao = primary;  // a scene with AO off: still measure any-hit rays
  }
};

void core_rays(benchmark::State& state, const Workload* w, const char* format, bool use_ao) {
  const std::vector<Ray>& rays = use_ao ? w->ao : w->primary;
  RayTraversal traversal(*w->trees.at(format).context);
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

void embree_rays(benchmark::State& state, const EmbreeScene* embree, const Workload* w, bool use_ao) {
  const std::vector<Ray>& rays = use_ao ? w->ao : w->primary;
  uint64_t hits = 0;
  for (auto _ : state) {
    for (const Ray& r : rays) {
      if (use_ao)
        hits += embree->occluded(r.origin, r.direction, r.tmin, r.tmax) ? 1 : 0;
      else
        hits += embree->intersect(r.origin, r.direction, r.tmin, r.tmax).hit ? 1 : 0;
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
  const std::string builder = bench_builder();
  benchmark::AddCustomContext("builder", builder);
  std::vector<std::unique_ptr<Workload>> workloads;
  for (const std::string& name : names) {
    try {
      workloads.push_back(std::make_unique<Workload>(name, builder));
    } catch (const std::exception& e) {  // e.g. an unknown RTSIM_BENCH_BUILDER, a damaged scene
      std::fprintf(stderr, "bench_trace: %s: %s\n", name.c_str(), e.what());
      return 2;
    }
    const Workload* w = workloads.back().get();
    for (bool ao : {false, true}) {
      const std::string kind = ao ? "ao/" : "primary/";
      for (const char* format : kFormats)
        benchmark::RegisterBenchmark(("core_" + kind + name + "/" + format).c_str(), core_rays, w, format, ao)
            ->Unit(benchmark::kMillisecond);
      const std::string call = ao ? "embree_occluded1_" : "embree_intersect1_";
      benchmark::RegisterBenchmark((call + "bvh4/" + name).c_str(), embree_rays, w->embree4.get(), w, ao)
          ->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark((call + "bvh8/" + name).c_str(), embree_rays, w->embree8.get(), w, ao)
          ->Unit(benchmark::kMillisecond);
    }
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
