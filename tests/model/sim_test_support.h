#pragma once
// Shared by the simulator tests: a small scene, a BVH, and running a SystemC
// level in a child process (SystemC allows one elaboration per process).
#include <rtsim/builder/build.h>
#include <rtsim/model/sim/simulator.h>
#include <rtsim/workloads/fork.h>
#include <rtsim/workloads/procedural.h>

#include <nlohmann/json.hpp>

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>

namespace rtsim::sim::test {

struct SmallWorkload {
  Scene scene = make_procedural_scene("cornell");
  Bvh bvh;
  std::string format;  // node record format; empty: the preset's
  explicit SmallWorkload(std::string node_format_name = "") : format(std::move(node_format_name)) {
    BuildParams params;
    params.builder = "sah";
    if (!format.empty()) apply_node_format(params, node_format(format));
    bvh = build_bvh(scene, params);
  }
  SimulationRequest request(Fidelity level, uint32_t size = 24, int ao = 4) const {
    SimulationRequest r;
    r.scene = &scene;
    r.bvh = &bvh;
    r.camera = &scene.cameras.front();
    r.settings.width = r.settings.height = size;
    r.settings.ao_samples = ao;
    r.config = preset("mobile");
    if (!format.empty()) r.config.node_format = format;
    r.fidelity = level;
    return r;
  }
};

// Runs fn in a forked child and returns the string it produced. The child is
// forked without the parent's worker threads (their locks would stay held in it),
// and one that has not answered within `limit_seconds` is killed and reported, so
// a stuck child fails its test instead of stalling the suite.
inline std::string in_child(const std::function<std::string()>& fn, int limit_seconds = 300) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t pid = fork_without_workers();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    close(fds[0]);
    std::string out;
    try {
      out = fn();
    } catch (const std::exception& e) {
      out = std::string("ERROR: ") + e.what();
    }
    size_t done = 0;
    while (done < out.size()) {
      const ssize_t n = write(fds[1], out.data() + done, out.size() - done);
      if (n <= 0) break;
      done += size_t(n);
    }
    close(fds[1]);
    _exit(0);
  }
  close(fds[1]);
  std::string out;
  char buffer[65536];
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(limit_seconds);
  bool timed_out = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now()).count();
    pollfd p{fds[0], POLLIN, 0};
    const int ready = left > 0 ? poll(&p, 1, int(left)) : 0;
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      timed_out = true;
      break;
    }
    const ssize_t n = read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    out.append(buffer, size_t(n));
  }
  close(fds[0]);
  if (timed_out) kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  if (timed_out)
    return "ERROR: the child did not finish within " + std::to_string(limit_seconds) + " s (killed)";
  return out;
}

// Flattens stats JSON to "a.b.c" -> value.
inline void flatten(const nlohmann::json& j, const std::string& prefix,
                    std::map<std::string, double>& out) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = prefix.empty() ? it.key() : prefix + "." + it.key();
    if (it->is_object() && it->contains("value") && it->contains("unit"))
      out[key] = (*it)["value"].get<double>();
    else if (it->is_object())
      flatten(*it, key, out);
  }
}

inline std::map<std::string, double> flat_stats(const std::string& json_text) {
  if (json_text.rfind("ERROR", 0) == 0) throw std::runtime_error(json_text);
  std::map<std::string, double> out;
  flatten(nlohmann::json::parse(json_text), "", out);
  return out;
}

// Stats of a small run from the scene's view1 (res x res pixels, 2 AO rays each) on
// the mobile preset: functional in this process, lt and cycle in a child (SystemC
// runs once per process).
inline std::map<std::string, double> small_run_stats(const Scene& scene, const Bvh& bvh, Fidelity level,
                                                     uint32_t res) {
  SimulationRequest r;
  r.scene = &scene;
  r.bvh = &bvh;
  r.camera = &scene.camera("view1");
  r.settings.width = r.settings.height = res;
  r.settings.ao_samples = 2;
  r.config = preset("mobile");
  r.fidelity = level;
  if (level == Fidelity::Functional) return flat_stats(simulate(r).stats.to_json());
  return flat_stats(in_child([&] { return simulate(r).stats.to_json(); }));
}

}  // namespace rtsim::sim::test
