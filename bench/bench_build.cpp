// Build speed: our binned sah vs Embree's medium build (rtcBuildBVH) on the default
// scene and, when fetched (RTSIM_CACHE/<name>/scene.toml), on dragon-small, dragon and
// black_forest; and the AO-BVH total (AO pass + build) vs sah, for K = 4 and 16 rays
// per estimate and G = 1, 16, 64 triangles sharing one. Run with
//   bench_build --benchmark_counters_tabular=true
// Also the EPO metric of each scene's sah tree (metrics/<scene>/epo).
// Threads: RTSIM_BENCH_THREADS (default 2, this machine's cores).
// Scenes: RTSIM_BENCH_SCENES, a comma-separated list (default: the above).
#include <rtsim/builder/build.h>
#include <rtsim/builder/metrics.h>
#include <rtsim/workloads/scene_registry.h>

#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <sstream>
#include <vector>

namespace {

uint32_t bench_threads() {
  const char* env = std::getenv("RTSIM_BENCH_THREADS");
  return env ? uint32_t(std::atoi(env)) : 2u;
}

const rtsim::Scene& scene_named(const std::string& name) {
  static std::map<std::string, std::unique_ptr<rtsim::Scene>> cache;
  auto& slot = cache[name];
  if (!slot) slot = std::make_unique<rtsim::Scene>(rtsim::load_scene(name));
  return *slot;
}

void run_build(benchmark::State& state, const std::string& scene_name, const std::string& builder,
               uint32_t ao_rays, uint32_t ao_share = 1) {
  const rtsim::Scene& scene = scene_named(scene_name);
  rtsim::BuildParams params;
  params.builder = builder;
  params.threads = bench_threads();
  params.ao_rays = ao_rays;
  params.ao_share = ao_share;
  double order = 0, estimate = 0, build = 0;
  for (auto _ : state) {
    rtsim::BuildReport report;
    rtsim::Bvh bvh = rtsim::build_bvh(scene, params, &report);
    benchmark::DoNotOptimize(bvh.nodes.data());
    order += report.order_seconds;
    estimate += report.estimate_seconds;
    build += report.build_seconds;
  }
  state.counters["triangles"] = double(scene.triangle_count());
  state.counters["order_s"] = order / double(state.iterations());
  state.counters["estimate_s"] = estimate / double(state.iterations());
  state.counters["build_s"] = build / double(state.iterations());
  state.counters["Mtri/s"] = benchmark::Counter(double(scene.triangle_count()) * 1e-6,
                                                benchmark::Counter::kIsIterationInvariantRate);
}

// The end-point overlap of the scene's sah tree (the tree is built once, outside the
// timing): the costliest of the quality metrics every build reports.
void run_epo(benchmark::State& state, const std::string& scene_name) {
  const rtsim::Scene& scene = scene_named(scene_name);
  rtsim::BuildParams params;
  params.threads = bench_threads();
  const rtsim::Bvh bvh = rtsim::build_bvh(scene, params);
  double epo = 0;
  for (auto _ : state) {
    epo = rtsim::end_point_overlap(bvh, scene, params.t1, params.t2);
    benchmark::DoNotOptimize(epo);
  }
  state.counters["nodes"] = double(bvh.nodes.size());
  state.counters["epo"] = epo;
}

void register_scene(const std::string& scene) {
  benchmark::RegisterBenchmark(("metrics/" + scene + "/epo").c_str(),
                               [scene](benchmark::State& s) { run_epo(s, scene); })
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->MinTime(2.0);
  for (const char* builder : {"sah", "embree"})
    benchmark::RegisterBenchmark(("build/" + scene + "/" + builder).c_str(),
                                 [scene, builder](benchmark::State& s) { run_build(s, scene, builder, 16); })
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->MinTime(2.0);
  // K rays per estimate, G triangles share one (G = 1: one per triangle); the
  // trade-off of docs/builders.md ("AO-BVH's sampling").
  const std::pair<uint32_t, uint32_t> variants[] = {{4, 1}, {4, 16}, {4, 64}, {16, 1}, {16, 4}, {16, 16}};
  for (auto [k, g] : variants)
    benchmark::RegisterBenchmark(
        ("build/" + scene + "/aobvh_K" + std::to_string(k) + "_G" + std::to_string(g)).c_str(),
        [scene, k = k, g = g](benchmark::State& s) { run_build(s, scene, "aobvh", k, g); })
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->MinTime(2.0);
}

}  // namespace

int main(int argc, char** argv) {
  // dragon-small (48k) and dragon (871k) are the same object at two sizes, and
  // black_forest (1.09M) the largest fetched scene: how build time grows with N
  // (n log n expected).
  std::vector<std::string> names;
  if (const char* list = std::getenv("RTSIM_BENCH_SCENES")) {
    std::stringstream in(list);
    for (std::string name; std::getline(in, name, ',');)
      if (!name.empty()) names.push_back(name);
  } else {
    names = {rtsim::default_scene_name(), "dragon-small", "dragon", "black_forest"};
  }
  for (const std::string& name : names) {
    // A built-in scene always loads; a real one only when fetched.
    const std::filesystem::path dir = rtsim::scene_cache_dir() / name;
    const bool builtin = name == "interior" || name == "cornell" || name == "foliage";
    if (builtin || std::filesystem::exists(dir / "scene.toml"))
      register_scene(name);
    else
      std::fprintf(stderr, "bench_build: %s not fetched, skipping %s\n", (dir / "scene.toml").c_str(),
                   name.c_str());
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
