#pragma once
// The one way rtsim runs a simulation (or a build) in a child process: SystemC
// elaborates once per process, so Table 1, the accuracy study and campaigns run
// `rtsim simulate` as children. A job is typed (SimulationJob, BuildJob); its
// arguments() are the only place its command line is spelt; JobRunner starts it
// (fork + exec, output to a log, the child dies with its parent), waits and
// returns typed results (stats.json, host.json, config.json), or throws with the
// log's last line. Campaigns exec the same arguments, so that a Slurm array or a
// GNU parallel list runs the very job lines a local run does.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace rtsim {

struct SimulationJob {
  std::string scene;                 // a name or a descriptor path
  std::string builder = "sah";
  std::string camera;                // empty: the scene's default
  std::string fidelity = "functional";
  std::string config = "mobile";     // a preset or a hardware TOML file
  std::vector<std::pair<std::string, std::string>> overrides;       // --set KEY=VALUE
  std::vector<std::pair<std::string, std::string>> build_settings;  // --build-set KEY=VALUE
  std::filesystem::path bvh;         // non-empty: replay this saved tree
  std::string node_format;           // empty: the configuration's
  std::string resolution;            // "WxH"; empty: the default
  int ao_rays = -1;                  // -1: the scene decides
  std::string ao_cutoff;             // empty: the scene's
  uint64_t seed = 1;
  uint32_t frames = 0;               // 0: the default (1)
  int64_t diffuse_bounces = -1;      // < 0: the default (none)
  bool opaque = false;               // alpha-tested materials as opaque (--opaque)
  bool instanced = false;            // the scene with its instances (--instanced)
  std::filesystem::path out_dir;
  // `simulate --scene ... --out-dir ...`: the child's arguments after the binary.
  std::vector<std::string> arguments() const;
};

struct BuildJob {
  std::string scene, builder = "sah", camera, node_format;
  uint64_t seed = 1;
  std::vector<std::pair<std::string, std::string>> build_settings;
  bool opaque = false;                // alpha-tested materials as opaque (--opaque)
  bool instanced = false;             // the two-level tree of the scene's instances (--instanced)
  std::filesystem::path out;          // the tree file
  std::filesystem::path metrics_out;  // optional
  std::vector<std::string> arguments() const;  // `build --scene ... --out ...`
};

struct SimulationOutcome {
  nlohmann::json stats, host, config;  // the job's stats.json, host.json, config.json
  double process_seconds = 0;          // wall time of the child, start to exit
};

class JobRunner {
 public:
  // binary: the rtsim to run (default: this executable).
  explicit JobRunner(std::filesystem::path binary = {});
  const std::filesystem::path& binary() const { return binary_; }
  // Runs one child with its output in `log`; throws std::runtime_error naming the
  // job and the log's last line when it fails or writes no results.
  SimulationOutcome simulate(const SimulationJob& job, const std::filesystem::path& log) const;
  void build(const BuildJob& job, const std::filesystem::path& log) const;
  // Every job, `parallel` at a time, with a progress line labelled `label`;
  // outcomes in job order. The first failure is thrown once all have ended.
  std::vector<SimulationOutcome> simulate_all(const std::vector<SimulationJob>& jobs,
                                              const std::vector<std::filesystem::path>& logs,
                                              uint32_t parallel, const std::string& label) const;

 private:
  void run(const std::vector<std::string>& arguments, const std::filesystem::path& log,
           const std::string& what) const;
  std::filesystem::path binary_;
};

// fork + exec of `program args...` with stdin from /dev/null and stdout and stderr
// into `log`; the child gets SIGKILL when its parent dies. Returns the child's pid.
int spawn_child(const std::filesystem::path& program, const std::vector<std::string>& args,
                const std::filesystem::path& log);
// "exit code 3", "killed by signal 9 (Killed)" for a wait status.
std::string describe_exit(int status);

}  // namespace rtsim
