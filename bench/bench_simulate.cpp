// Simulated rays per host second at each fidelity level on one core: default
// scene ("interior"), primary rays + 4 AO rays per primary hit, mobile preset.
// SystemC allows one elaboration per process, so every timed run happens in a
// forked child; the scene and BVH are built once in the parent. The reported
// time is the simulation proper (SimulationResult::host_seconds).
//   bench_simulate [--benchmark_filter=cycle] ; env RTSIM_BENCH_RES=WxH (default 128x128),
//   RTSIM_BENCH_BUILDER=NAME (default sah)
#include "bench_env.h"

#include <rtsim/builder/build.h>
#include <rtsim/model/sim/simulator.h>
#include <rtsim/workloads/fork.h>
#include <rtsim/workloads/numbers.h>
#include <rtsim/workloads/scene_registry.h>

#include <benchmark/benchmark.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>

using namespace rtsim;
using namespace rtsim::sim;

namespace {

struct Fixture {
  Scene scene = load_scene(default_scene_name());
  Bvh bvh;
  uint32_t width = 128, height = 128;
  Fixture() {
    if (const char* res = std::getenv("RTSIM_BENCH_RES")) read_size_text(res, kMaxResolutionSide, "RTSIM_BENCH_RES", width, height);
    BuildParams params;
    params.builder = bench_builder();
    bvh = build_bvh(scene, params);
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

struct Measured {
  double host_seconds = 0;
  double cpu_seconds = 0;
  double rays = 0;
  double cycles = 0;
};

Measured run_in_child(Fidelity level) {
  Fixture& f = fixture();
  int fds[2];
  if (pipe(fds) != 0) std::abort();
  const pid_t pid = fork_without_workers();
  if (pid == 0) {
    close(fds[0]);
    SimulationRequest r;
    r.scene = &f.scene;
    r.bvh = &f.bvh;
    r.camera = &f.scene.cameras.front();
    r.settings.width = f.width;
    r.settings.height = f.height;
    r.settings.ao_samples = 4;
    r.settings.shadows = r.settings.reflections = r.settings.refractions = false;
    r.config = preset("mobile");
    r.fidelity = level;
    const SimulationResult result = simulate(r);
    Measured m{result.host_seconds, result.cpu_seconds, double(result.rays), double(result.cycles)};
    if (write(fds[1], &m, sizeof m) != sizeof m) _exit(1);
    _exit(0);
  }
  close(fds[1]);
  Measured m;
  if (read(fds[0], &m, sizeof m) != sizeof m) std::abort();
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return m;
}

void BM_Simulate(benchmark::State& state, Fidelity level) {
  fixture();  // build outside the timed region
  Measured last;
  double rays = 0, seconds = 0, cpu = 0;
  for (auto _ : state) {
    last = run_in_child(level);
    state.SetIterationTime(last.host_seconds);
    rays += last.rays;
    seconds += last.host_seconds;
    cpu += last.cpu_seconds;
  }
  state.counters["rays"] = last.rays;
  state.counters["sim_cycles"] = last.cycles;
  state.counters["rays_per_host_second"] = seconds > 0 ? rays / seconds : 0;
  // CPU time: the fair figure when other work shares the machine.
  state.counters["rays_per_cpu_second"] = cpu > 0 ? rays / cpu : 0;
}

}  // namespace

BENCHMARK_CAPTURE(BM_Simulate, functional, Fidelity::Functional)->UseManualTime()->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(BM_Simulate, lt, Fidelity::Lt)->UseManualTime()->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_CAPTURE(BM_Simulate, cycle, Fidelity::Cycle)->UseManualTime()->Unit(benchmark::kMillisecond)->MinTime(1.0);

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  // The scene and tree are built here, before any run, so that a bad
  // RTSIM_BENCH_RES or RTSIM_BENCH_BUILDER is a message and exit 2, not an
  // exception inside a benchmark.
  try {
    fixture();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_simulate: %s\n", e.what());
    return 2;
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
