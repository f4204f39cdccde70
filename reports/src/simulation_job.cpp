#include <rtsim/reports/child_process.h>
#include <rtsim/reports/simulation_job.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/progress.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace rtsim {

namespace fs = std::filesystem;

std::vector<std::string> SimulationJob::arguments() const {
  std::vector<std::string> a = {"simulate", "--scene", scene, "--fidelity", fidelity, "--config", config,
                                "--seed", std::to_string(seed), "--out-dir", out_dir.string()};
  // A saved tree carries its builder (simulate refuses a --builder that differs).
  if (bvh.empty()) a.insert(a.begin() + 3, {"--builder", builder});
  if (!camera.empty()) a.insert(a.end(), {"--camera", camera});
  if (!resolution.empty()) a.insert(a.end(), {"--res", resolution});
  if (ao_rays >= 0) a.insert(a.end(), {"--ao", std::to_string(ao_rays)});
  if (!ao_cutoff.empty()) a.insert(a.end(), {"--ao-cutoff", ao_cutoff});
  if (frames > 0) a.insert(a.end(), {"--frames", std::to_string(frames)});
  if (diffuse_bounces >= 0) a.insert(a.end(), {"--diffuse-bounces", std::to_string(diffuse_bounces)});
  if (opaque) a.push_back("--opaque");
  if (instanced) a.push_back("--instanced");
  if (!node_format.empty()) a.insert(a.end(), {"--node-format", node_format});
  if (!bvh.empty()) a.insert(a.end(), {"--bvh", bvh.string()});
  for (const auto& [k, v] : overrides) a.insert(a.end(), {"--set", k + "=" + v});
  // A saved tree carries its builder parameters (simulate refuses --build-set with --bvh).
  if (bvh.empty())
    for (const auto& [k, v] : build_settings) a.insert(a.end(), {"--build-set", k + "=" + v});
  return a;
}

std::vector<std::string> BuildJob::arguments() const {
  std::vector<std::string> a = {"build", "--scene", scene, "--builder", builder,
                                "--seed", std::to_string(seed), "--out", out.string()};
  if (!metrics_out.empty()) a.insert(a.end(), {"--metrics-out", metrics_out.string()});
  // The seed and the camera have their own flags (--camera after a build.camera
  // setting would undo it).
  for (const auto& [k, v] : build_settings)
    if (k != "seed" && k != "camera") a.insert(a.end(), {"--build-set", k + "=" + v});
  if (!camera.empty()) a.insert(a.end(), {"--camera", camera});
  if (!node_format.empty()) a.insert(a.end(), {"--node-format", node_format});
  if (opaque) a.push_back("--opaque");
  if (instanced) a.push_back("--instanced");
  return a;
}

int spawn_child(const fs::path& program, const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> words;
  words.push_back(program.string());
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  const std::string log_path = log.string();
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    // Only async-signal-safe calls from here on. The child dies with its parent, so a
    // kill -9 of rtsim never leaves orphans writing into directories a rerun reuses.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(126);  // the parent died before prctl took effect
    const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    const int null_fd = open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (fd < 0 || null_fd < 0) _exit(126);
    dup2(null_fd, 0);
    dup2(fd, 1);
    dup2(fd, 2);
    execv(argv[0], argv.data());
    const char msg[] = "rtsim: cannot execute the job binary\n";
    (void)!write(2, msg, sizeof msg - 1);
    _exit(127);
  }
  return pid;
}

std::string describe_exit(int status) {
  if (WIFEXITED(status)) return "exit code " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    return "killed by signal " + std::to_string(sig) + " (" + strsignal(sig) + ")";
  }
  return "ended with wait status " + std::to_string(status);
}

namespace {

// The last non-empty line of a log: usually the reason a run failed.
std::string last_line(const fs::path& log) {
  std::string text;
  try {
    text = read_input_file(log, kMaxConfigFileBytes);
  } catch (const std::exception&) {
    return "";
  }
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  const size_t nl = text.rfind('\n');
  return nl == std::string::npos ? text : text.substr(nl + 1);
}

nlohmann::json read_result(const fs::path& file, const std::string& what) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(what + ": " + file.string() + " was not written");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(what + ": " + file.string() + " is not JSON (" + e.what() + ")");
  }
}

std::string describe(const SimulationJob& job) {
  return "the " + job.fidelity + " run of " + job.scene + "/" + job.builder +
         (job.camera.empty() ? "" : "/" + job.camera);
}

}  // namespace

JobRunner::JobRunner(fs::path binary) : binary_(binary.empty() ? self_executable() : std::move(binary)) {}

void JobRunner::run(const std::vector<std::string>& arguments, const fs::path& log,
                    const std::string& what) const {
  if (!log.parent_path().empty()) fs::create_directories(log.parent_path());
  const pid_t pid = spawn_child(binary_, arguments, log);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw std::runtime_error(std::string("waitpid: ") + std::strerror(errno));
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  const std::string said = last_line(log);
  throw std::runtime_error(what + " failed (" + describe_exit(status) + "): " +
                           (said.empty() ? "no output" : said) + " (log " + log.string() + ")");
}

SimulationOutcome JobRunner::simulate(const SimulationJob& job, const fs::path& log) const {
  const auto start = std::chrono::steady_clock::now();
  const std::string what = describe(job);
  run(job.arguments(), log, what);
  SimulationOutcome out;
  out.process_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.stats = read_result(job.out_dir / "stats.json", what);
  out.host = read_result(job.out_dir / "host.json", what);
  out.config = read_result(job.out_dir / "config.json", what);
  return out;
}

void JobRunner::build(const BuildJob& job, const fs::path& log) const {
  run(job.arguments(), log, "the " + job.builder + " build of " + job.scene);
}

std::vector<SimulationOutcome> JobRunner::simulate_all(const std::vector<SimulationJob>& jobs,
                                                       const std::vector<fs::path>& logs,
                                                       uint32_t parallel, const std::string& label) const {
  if (logs.size() != jobs.size()) throw std::logic_error("simulate_all: one log per job");
  std::vector<SimulationOutcome> outcomes(jobs.size());
  Progress progress(label, jobs.size(), "runs");
  std::atomic<size_t> next{0};
  std::mutex failure_mutex;
  std::string failure;
  const auto worker = [&] {
    for (size_t i = next++; i < jobs.size(); i = next++) {
      try {
        outcomes[i] = simulate(jobs[i], logs[i]);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (failure.empty()) failure = e.what();
      }
      progress.advance();
    }
  };
  std::vector<std::thread> threads;
  for (uint32_t t = 0; t < std::max(1u, parallel); ++t) threads.emplace_back(worker);
  for (std::thread& t : threads) t.join();
  if (!failure.empty()) throw std::runtime_error(failure);
  return outcomes;
}

}  // namespace rtsim
