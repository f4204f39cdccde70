// Collapse speed: a binary SAH tree (leaves of at most 3 triangles, the
// tightest format's capacity) collapsed to 4, 6 and 8 children, on the default
// scene and, when fetched (RTSIM_CACHE/<name>/scene.toml), dragon and
// black_forest. Counter Mtri/s: million scene triangles collapsed per second (its
// inverse is the collapse time per million triangles). Single-threaded: the pass is.
#include <rtsim/builder/build.h>
#include <rtsim/builder/collapse.h>
#include <rtsim/workloads/scene_registry.h>

#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>

namespace {

struct Binary {
  size_t triangles = 0;
  rtsim::Bvh bvh;
};

const Binary& binary_tree(const std::string& scene_name) {
  static std::map<std::string, std::unique_ptr<Binary>> cache;
  auto& slot = cache[scene_name];
  if (!slot) {
    const rtsim::Scene scene = rtsim::load_scene(scene_name);
    rtsim::BuildParams params;
    params.builder = "sah";
    params.max_leaf_size = 3;
    slot = std::make_unique<Binary>();
    slot->triangles = scene.triangle_count();
    slot->bvh = rtsim::build_bvh(scene, params);
  }
  return *slot;
}

void run_collapse(benchmark::State& state, const std::string& scene, uint32_t width) {
  const Binary& b = binary_tree(scene);
  rtsim::CollapseParams params;
  params.width = width;
  params.max_leaf_size = 3;
  size_t nodes = 0;
  for (auto _ : state) {
    rtsim::Bvh wide = rtsim::collapse_bvh(b.bvh, params);
    nodes = wide.nodes.size();
    benchmark::DoNotOptimize(wide.nodes.data());
  }
  state.counters["triangles"] = double(b.triangles);
  state.counters["binary_nodes"] = double(b.bvh.nodes.size());
  state.counters["wide_nodes"] = double(nodes);
  state.counters["Mtri/s"] =
      benchmark::Counter(double(b.triangles) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::vector<std::string> scenes{rtsim::default_scene_name()};
  for (const char* name : {"dragon", "black_forest"})
    if (std::filesystem::exists(rtsim::scene_cache_dir() / name / "scene.toml")) scenes.push_back(name);
  for (const std::string& scene : scenes)
    for (uint32_t width : {4u, 6u, 8u})
      benchmark::RegisterBenchmark(("collapse/" + scene + "/width" + std::to_string(width)).c_str(),
                                   [scene, width](benchmark::State& s) { run_collapse(s, scene, width); })
          ->Unit(benchmark::kMillisecond)
          ->MinTime(1.0);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
