// Campaign execution: one child process per job, result files, resume, collect, emit.
#include <rtsim/reports/campaign_runner.h>
#include <rtsim/reports/simulation_job.h>

#include <rtsim/builder/build.h>
#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/node_format.h>

#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/numbers.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

namespace rtsim {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The last lines of a job's log: enough to see why it failed, small enough for a cell.
std::string log_tail(const fs::path& log, size_t max_chars = 2000) {
  std::string text = read_text(log);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  if (text.size() > max_chars) {
    text = text.substr(text.size() - max_chars);
    const size_t nl = text.find('\n');
    if (nl != std::string::npos) text = text.substr(nl + 1);
    text = "..." + std::string("\n") + text;
  }
  return text;
}

// A started child process.
struct Child {
  pid_t pid = -1;
  Clock::time_point start;
};

Child spawn(const fs::path& binary, const std::vector<std::string>& args, const fs::path& log) {
  Child c;
  c.start = Clock::now();
  c.pid = spawn_child(binary, args, log);
  return c;
}

// Reads a JSON output of a job; null if absent or unreadable (the reason in `why`).
json read_json_output(const fs::path& p, std::string& why) {
  if (!fs::exists(p)) {
    why = p.filename().string() + " was not written";
    return nullptr;
  }
  try {
    return json::parse(read_text(p));
  } catch (const std::exception& e) {
    why = p.filename().string() + " is not valid JSON: " + e.what();
    return nullptr;
  }
}

RunRecord make_record(const Campaign& campaign, const CampaignJob& job, const CampaignPaths& paths,
                      int wait_status, bool timed_out, double seconds) {
  RunRecord r;
  r.campaign = campaign.name;
  r.job_key = job.key;
  r.label = job.label;
  r.group = job.group;
  r.config_hash = job.config_hash;
  r.revision = campaign.revision;
  r.host_seconds = seconds;
  r.finished_at = utc_now();
  r.job = job.resolved;
  const fs::path dir = paths.job_dir(job.key);
  std::string why_config, why_stats;
  r.config = read_json_output(dir / "config.json", why_config);
  r.stats = read_json_output(dir / "stats.json", why_stats);
  std::string why_host;  // host.json is optional (older simulators put host time in stats)
  r.host = read_json_output(dir / "host.json", why_host);
  const bool exited_ok = !timed_out && WIFEXITED(wait_status) && WEXITSTATUS(wait_status) == 0;
  if (exited_ok && r.stats.is_object() && r.config.is_object()) {
    r.status = "ok";
  } else {
    r.status = "failed";
    std::string reason = timed_out ? "timed out" : describe_exit(wait_status);
    if (exited_ok) reason = !why_stats.empty() ? why_stats : !why_config.empty() ? why_config
                                                                                 : "bad outputs";
    const std::string tail = log_tail(dir / "log.txt");
    // The first line is what `run` and `status` show: how it ended and the last
    // thing the job said (usually its error message); the log's tail follows.
    const std::string last = tail.substr(tail.rfind('\n') == std::string::npos ? 0 : tail.rfind('\n') + 1);
    r.error = reason + (last.empty() ? "" : ": " + last) + (tail.empty() ? "" : "\n" + tail);
  }
  return r;
}

void write_result_file(const CampaignPaths& paths, const RunRecord& r) {
  fs::create_directories(paths.dir / "results");
  write_file_atomic(paths.result_file(r.job_key), r.to_json().dump(1) + "\n");
}

// Prepares a clean job directory (a killed earlier attempt may have left files).
fs::path fresh_job_dir(const CampaignPaths& paths, const std::string& key) {
  const fs::path dir = paths.job_dir(key);
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir);
  return dir;
}

// A cached tree that fails its own checks (truncated, checksum mismatch: a disk
// error, an interrupted copy) would fail every job that replays it, for ever; it
// is moved aside so that the next job builds it again. Checked once per process
// and file: a tree being built is only renamed into place when complete.
// Why a cached tree is not the tree `job` asks for ("" when it is): the header's
// builder and the parameters that shape the tree (build_params_json, as `rtsim
// build` writes it) against the job's. The scene is checked by simulate itself
// (load_bvh with the scene: its hash and triangle count), a refusal, not a wrong tree.
std::string tree_mismatch(const BvhFileHeader& header, const CampaignJob& job) {
  if (header.builder != job.builder)
    return "it holds a tree built by '" + header.builder + "', the job asks for '" + job.builder + "'";
  BuildParams expected;
  expected.builder = job.builder;
  expected.seed = job.seed;
  for (const auto& [k, v] : job.build_settings) set_build_parameter(expected, k, v);
  if (!job.tree_camera().empty()) expected.camera = job.tree_camera();
  if (!job.node_format.empty()) apply_node_format(expected, node_format(job.node_format));
  const json want = json::parse(build_params_json(expected));
  const json have = json::parse(header.params_json, nullptr, /*allow_exceptions=*/false);
  if (!have.is_object()) return "its parameters are not a JSON object";
  for (const auto& [key, value] : want.items()) {
    if (key == "camera" && job.tree_camera().empty()) continue;  // the build's default camera
    if (key == "width" && !have.contains(key) && value == 2) continue;  // binary trees leave it out
    if (!have.contains(key) || have.at(key) != value)
      return "its " + key + " is " + (have.contains(key) ? have.at(key).dump() : std::string("absent")) +
             ", the job asks for " + value.dump();
  }
  return "";
}

// A cached tree that cannot be read, or that is not the job's tree (a file copied
// over it, a key collision), is moved aside and built again, never used.
void discard_unusable_tree(const fs::path& tree, const CampaignJob& job) {
  static std::set<std::string> checked;
  if (!checked.insert(tree.string()).second || !is_file(tree)) return;
  std::string why;
  try {
    BvhFileHeader header;
    load_bvh(tree, nullptr, &header);
    why = tree_mismatch(header, job);
  } catch (const InputError& e) {
    why = std::string("it is damaged (") + e.what() + ")";
  }
  if (why.empty()) return;
  fs::path aside = tree;
  aside += why.rfind("it is damaged", 0) == 0 ? ".damaged" : ".mismatch";
  std::error_code ec;
  fs::rename(tree, aside, ec);
  std::fprintf(stderr, "rtsim campaign: tree cache: %s is not this job's tree: %s; it is built again%s\n",
               tree.string().c_str(), why.c_str(),
               ec ? "" : (" (the file is kept as " + aside.filename().string() + ")").c_str());
}

// What a job process executes: the binary and its arguments.
struct JobCommand {
  fs::path program;
  std::vector<std::string> args;
};

// A clean job directory with the job's hardware file, and the command: `simulate`
// directly, or with a tree cache a small shell step that builds the shared tree once
// (under flock, so concurrent jobs wait for one build) and then execs `simulate --bvh`.
JobCommand prepare_job(const Campaign& campaign, const CampaignPaths& paths, const CampaignJob& job,
                       const fs::path& binary, const fs::path& tree_cache) {
  const fs::path dir = fresh_job_dir(paths, job.key);
  std::vector<std::string> args;
  if (job.hardware_toml.empty()) {
    args = job.simulate_arguments(dir);
  } else {
    const fs::path hardware = dir / "hardware.toml";
    write_file_atomic(hardware, "# " + job.label + "\n" + job.hardware_toml);
    args = job.simulate_arguments(dir, hardware);
  }
  if (tree_cache.empty()) return {binary, args};
  const fs::path tree = cached_tree(tree_cache, campaign, job);
  fs::create_directories(tree_cache);
  discard_unusable_tree(tree, job);
  BuildJob build_job;
  build_job.scene = job.scene_path.empty() ? job.scene : job.scene_path.string();
  build_job.builder = job.builder;
  build_job.seed = job.build_settings.count("seed") ? read_unsigned(job.build_settings.at("seed"), 0, UINT64_MAX, "build.seed")
                                                    : job.seed;
  build_job.build_settings.assign(job.build_settings.begin(), job.build_settings.end());
  build_job.camera = job.tree_camera();
  build_job.node_format = job.node_format;
  build_job.opaque = job.opaque;
  build_job.instanced = job.instanced;
  build_job.out = "$T";
  build_job.metrics_out = "$T.metrics.json";
  // The tree's path is the script's $T: those two words stay unquoted for the shell.
  std::string build = shell_quote(binary.string());
  for (const std::string& word : build_job.arguments())
    build += " " + (word.rfind("$T", 0) == 0 ? "\"" + word + "\"" : shell_quote(word));
  // The builder parameters went to the build; the saved tree carries them (simulate
  // refuses --build-set with --bvh, which would change nothing).
  std::string simulate = "exec " + shell_quote(binary.string());
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--build-set" && i + 1 < args.size()) {
      ++i;
      continue;
    }
    simulate += " " + shell_quote(args[i]);
  }
  simulate += " --bvh \"$T\"";
  // Inside flock: "$0" is the tree, "$@" the build command; rebuilt only if still absent.
  const std::string script = "T=" + shell_quote(tree.string()) +
                             "\nif [ ! -s \"$T\" ]; then\n"
                             "  flock \"$T.lock\" sh -c '[ -s \"$0\" ] || exec \"$@\"' \"$T\" " +
                             build + " || exit $?\nfi\n" + simulate + "\n";
  return {"/bin/sh", {"-c", script}};
}

std::atomic<int> g_stop_signal{0};
void on_stop_signal(int sig) { g_stop_signal = sig; }

std::string format_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  char buf[32];
  const long t = std::lround(s);
  if (t >= 3600) std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, (t / 60) % 60);
  else if (t >= 60) std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  else std::snprintf(buf, sizeof buf, "%lds", t);
  return buf;
}

// One exclusive lock per campaign directory; flock is released by the kernel when the
// holder dies, kill -9 included, so a stale lock never blocks a resume.
class CampaignLock {
 public:
  explicit CampaignLock(const fs::path& dir) {
    fs::create_directories(dir);
    const fs::path file = dir / "run.lock";
    fd_ = open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw std::runtime_error(file.string() + ": " + std::strerror(errno));
    if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      close(fd_);
      throw InputError(dir.string(), "another `rtsim campaign run` is using this campaign "
                                     "directory (run.lock is held)");
    }
  }
  ~CampaignLock() { close(fd_); }

 private:
  int fd_ = -1;
};

}  // namespace

std::string binary_revision(const fs::path& binary) {
  if (access(binary.c_str(), X_OK) != 0)
    throw InputError(binary.string(), "the job binary is not an executable file");
  const std::string command = shell_quote(binary.string()) + " --version 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) throw InputError(binary.string(), "cannot run --version");
  std::string out;
  char buf[256];
  while (fgets(buf, sizeof buf, pipe)) out += buf;
  const int status = pclose(pipe);
  if (status != 0 || out.empty())
    throw InputError(binary.string(), "`--version` failed; is it an rtsim binary?");
  out = out.substr(0, out.find('\n'));
  const size_t open_paren = out.rfind('('), close_paren = out.rfind(')');
  if (open_paren != std::string::npos && close_paren != std::string::npos &&
      close_paren > open_paren + 1)
    return out.substr(open_paren + 1, close_paren - open_paren - 1);
  return out;
}

CampaignPaths campaign_paths(const Campaign& campaign, const fs::path& dir_option,
                             const fs::path& database_option) {
  CampaignPaths p;
  // By default beside the campaign file, so every command finds the same folder
  // wherever it is run from.
  p.dir = fs::absolute(dir_option.empty() ? campaign.file.parent_path() / "rtsim-campaigns" / campaign.name
                                          : dir_option).lexically_normal();
  p.database = fs::absolute(database_option.empty() ? p.dir / "results.sqlite"
                                                    : database_option).lexically_normal();
  return p;
}

fs::path cached_tree(const fs::path& cache, const Campaign& campaign, const CampaignJob& job) {
  // What shapes the tree, and nothing else, so that jobs differing only in what the
  // builder ignores (the workload's seed for sah, the camera for sbvh, an AO knob for
  // median) share one tree.
  json identity = {{"scene", job.scene},
                   {"scene_files_hash", job.resolved.value("scene_files_hash", "")},
                   {"builder", job.builder},
                   {"revision", campaign.revision}};
  BuildParams params;
  params.builder = job.builder;
  for (const auto& [k, v] : job.build_settings) set_build_parameter(params, k, v);  // checked on load
  if (tree_depends_on_camera(params)) identity["camera"] = job.tree_camera();
  const BuilderParameter& seed = *find_builder_parameter("seed");
  if (parameter_used_by(seed, job.builder) && !job.build_settings.count("seed")) identity["seed"] = job.seed;
  if (!job.node_format.empty()) identity["node_format"] = job.node_format;
  if (job.opaque) identity["opaque"] = true;  // another scene: its alpha-tested materials opaque
  if (job.instanced) identity["instanced"] = true;  // the two-level tree of the scene's instances
  json build = json::object();
  for (const auto& [k, v] : job.build_settings) {
    const BuilderParameter* p = find_builder_parameter(k);
    if (p && p->in_tree_identity && parameter_used_by(*p, job.builder) && k != "camera") build[k] = v;
  }
  if (!build.empty()) identity["build"] = build;
  return cache / (content_hash_hex(identity.dump()) + ".bvh");
}

fs::path cached_result(const fs::path& cache, const std::string& job_key, const std::string& binary_hash) {
  return cache / (job_key + "-" + binary_hash + ".json");
}

namespace {

// The job's result from the results cache, as this campaign's record (its name,
// label and group; the run's numbers as they were); false when there is none that
// is ok and this job's.
bool reuse_cached_result(const Campaign& campaign, const CampaignJob& job, const fs::path& cache,
                         const std::string& binary_hash, RunRecord& out) {
  if (cache.empty()) return false;
  const fs::path file = cached_result(cache, job.key, binary_hash);
  if (!is_file(file)) return false;
  try {
    RunRecord r = RunRecord::from_json(json::parse(read_text(file)), file.string());
    if (r.status != "ok" || r.job_key != job.key) return false;
    r.campaign = campaign.name;
    r.label = job.label;
    r.group = job.group;
    r.job = job.resolved;
    out = std::move(r);
    return true;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtsim campaign: results cache: %s cannot be read (%s); the job runs\n",
                 file.string().c_str(), e.what());
    return false;
  }
}

// Every ok run goes into the results cache, atomically (a killed runner leaves the
// previous file or none). A cache that cannot be written costs only the reuse.
void store_cached_result(const fs::path& cache, const std::string& binary_hash, const RunRecord& r) {
  if (cache.empty() || r.status != "ok") return;
  try {
    fs::create_directories(cache);
    write_file_atomic(cached_result(cache, r.job_key, binary_hash), r.to_json().dump(1) + "\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtsim campaign: results cache: cannot keep %s: %s\n", r.job_key.c_str(), e.what());
  }
}

}  // namespace

RunRecord run_one_job(const Campaign& campaign, const CampaignJob& job, const CampaignPaths& paths,
                      const fs::path& binary, double timeout_seconds, bool force,
                      const fs::path& tree_cache) {
  if (!force && fs::exists(paths.result_file(job.key))) {
    try {
      RunRecord done = RunRecord::from_json(json::parse(read_text(paths.result_file(job.key))),
                                            paths.result_file(job.key).string());
      if (done.status == "ok") return done;
    } catch (const std::exception&) {
      // An unreadable result file is rerun.
    }
  }
  const JobCommand command = prepare_job(campaign, paths, job, binary, tree_cache);
  Child c = spawn(command.program, command.args, paths.job_dir(job.key) / "log.txt");
  int status = 0;
  bool timed_out = false;
  for (;;) {
    const pid_t r = waitpid(c.pid, &status, timeout_seconds > 0 ? WNOHANG : 0);
    if (r == c.pid) break;
    if (r < 0 && errno != EINTR) throw std::runtime_error(std::string("waitpid: ") + std::strerror(errno));
    if (timeout_seconds > 0 &&
        std::chrono::duration<double>(Clock::now() - c.start).count() > timeout_seconds) {
      kill(c.pid, SIGKILL);
      timed_out = true;
    }
    if (timeout_seconds > 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - c.start).count();
  RunRecord r = make_record(campaign, job, paths, status, timed_out, seconds);
  write_result_file(paths, r);
  return r;
}

CollectSummary collect_results(const Campaign& campaign, const CampaignPaths& paths,
                               ResultsStore& store) {
  CollectSummary s;
  const fs::path folder = paths.dir / "results";
  if (!fs::is_directory(folder)) return s;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_regular_file() && e.path().extension() == ".json") files.push_back(e.path());
  std::sort(files.begin(), files.end());  // deterministic order of merging
  std::set<std::string> keys;
  for (const CampaignJob& j : campaign.jobs) keys.insert(j.key);
  for (const fs::path& f : files) {
    ++s.files;
    RunRecord r;
    try {
      r = RunRecord::from_json(json::parse(read_text(f)), f.string());
    } catch (const std::exception& e) {
      ++s.bad;
      s.problems.push_back(f.string() + ": " + e.what());
      continue;
    }
    if (r.campaign != campaign.name || !keys.count(r.job_key)) {
      ++s.stale;
      s.problems.push_back(f.string() + ": not a job of this campaign at revision " +
                           campaign.revision + " (stale; left out)");
      continue;
    }
    switch (store.record(r)) {
      case ResultsStore::Outcome::Inserted: ++s.inserted; break;
      case ResultsStore::Outcome::Replaced: ++s.replaced; break;
      case ResultsStore::Outcome::Unchanged: ++s.unchanged; break;
      case ResultsStore::Outcome::KeptOk: ++s.kept_ok; break;
    }
  }
  return s;
}

RunSummary run_campaign(const Campaign& campaign, const CampaignPaths& paths,
                        const RunOptions& options) {
  const auto wall_start = Clock::now();
  CampaignLock lock(paths.dir);
  ResultsStore store(paths.database);
  RunSummary summary;
  summary.total = campaign.jobs.size();
  // Results written by a runner killed between its result file and its transaction.
  summary.collected = collect_results(campaign, paths, store).inserted;

  const auto recorded = store.summaries(campaign.name);
  std::set<std::string> only(options.only_keys.begin(), options.only_keys.end());
  const fs::path binary = options.binary.empty() ? self_executable() : options.binary;
  const std::string binary_hash = options.results_cache.empty() ? std::string() : file_hash_hex(binary);
  std::vector<const CampaignJob*> todo;
  for (const CampaignJob& job : campaign.jobs) {
    if (!only.empty() && !only.count(job.key)) continue;
    auto it = recorded.find(job.key);
    if (!options.force && it != recorded.end()) {
      if (it->second.status == "ok") { ++summary.already_ok; continue; }
      if (!options.retry_failed) { ++summary.skipped_failed; continue; }
    }
    // Run before under another campaign (or another folder): its result is this job's.
    RunRecord reused;
    if (!options.force && reuse_cached_result(campaign, job, options.results_cache, binary_hash, reused)) {
      // As a run records itself: the result file first, then the transaction.
      write_result_file(paths, reused);
      store.record(reused);
      ++summary.reused;
      continue;
    }
    todo.push_back(&job);
  }

  const int parallel = std::max(1, options.parallel);
  // The runner's children: quiet progress bars, same cache folder.
  setenv("RTSIM_NO_PROGRESS", "1", 1);

  g_stop_signal = 0;
  struct sigaction action {}, old_int{}, old_term{};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &old_int);
  sigaction(SIGTERM, &action, &old_term);

  std::map<pid_t, std::pair<const CampaignJob*, Child>> running;
  size_t next = 0;
  double finished_seconds = 0;
  auto last_draw = Clock::now() - std::chrono::seconds(1);
  auto draw = [&](bool final) {
    if (!options.progress) return;
    const size_t left = todo.size() - next;
    const size_t finished = summary.ok + summary.failed;
    std::string eta = "?";
    if (finished > 0) {
      const double mean = finished_seconds / double(finished);
      eta = format_duration(mean * double(left + running.size()) /
                            double(std::min<size_t>(parallel, left + running.size() + 1)));
    }
    std::fprintf(stderr, "\r%s: %zu done, %zu failed, %zu running, %zu left, ETA %s\x1b[K",
                 campaign.name.c_str(), summary.already_ok + summary.ok, summary.failed,
                 running.size(), left, final ? "0s" : eta.c_str());
    if (final) std::fputc('\n', stderr);
    std::fflush(stderr);
  };

  while ((next < todo.size() || !running.empty())) {
    if (g_stop_signal) break;
    while (running.size() < size_t(parallel) && next < todo.size()) {
      const CampaignJob* job = todo[next++];
      const JobCommand command = prepare_job(campaign, paths, *job, binary, options.tree_cache);
      Child c = spawn(command.program, command.args, paths.job_dir(job->key) / "log.txt");
      running.emplace(c.pid, std::make_pair(job, c));
    }
    int status = 0;
    const pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid > 0) {
      auto it = running.find(pid);
      if (it == running.end()) continue;
      const CampaignJob* job = it->second.first;
      const double seconds =
          std::chrono::duration<double>(Clock::now() - it->second.second.start).count();
      running.erase(it);
      const RunRecord r = make_record(campaign, *job, paths, status, false, seconds);
      // The result file first, then the transaction: a kill between the two is healed
      // by the next run's collect, never by running the job again.
      write_result_file(paths, r);
      store.record(r);
      store_cached_result(options.results_cache, binary_hash, r);
      ++summary.ran;
      finished_seconds += seconds;
      if (r.status == "ok") {
        ++summary.ok;
      } else {
        ++summary.failed;
        if (options.progress) std::fputc('\n', stderr);
        std::fprintf(stderr, "rtsim campaign: job %s (%s) failed: %s\n", job->key.c_str(),
                     job->label.c_str(), r.error.substr(0, r.error.find('\n')).c_str());
      }
      draw(false);
      continue;
    }
    if (pid < 0 && errno != EINTR && errno != ECHILD)
      throw std::runtime_error(std::string("waitpid: ") + std::strerror(errno));
    if (options.timeout_seconds > 0)
      for (auto& [p, entry] : running)
        if (std::chrono::duration<double>(Clock::now() - entry.second.start).count() >
            options.timeout_seconds)
          kill(p, SIGKILL);  // recorded as failed ("killed by signal 9") when reaped
    if (Clock::now() - last_draw > std::chrono::milliseconds(500)) {
      draw(false);
      last_draw = Clock::now();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }

  if (g_stop_signal) {
    summary.interrupted = true;
    for (auto& [p, entry] : running) kill(p, SIGTERM);
    for (auto& [p, entry] : running) waitpid(p, nullptr, 0);
  }
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  draw(true);
  summary.wall_seconds = std::chrono::duration<double>(Clock::now() - wall_start).count();
  return summary;
}

namespace {

// True if a `campaign run` holds the campaign directory's lock right now.
bool runner_active(const fs::path& dir) {
  const fs::path file = dir / "run.lock";
  const int fd = open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = flock(fd, LOCK_SH | LOCK_NB) != 0;
  if (!held) flock(fd, LOCK_UN);
  close(fd);
  return held;
}

}  // namespace

CampaignStatus campaign_status(const Campaign& campaign, const CampaignPaths& paths,
                               const ResultsStore& store) {
  CampaignStatus s;
  const auto recorded = store.summaries(campaign.name);
  s.total = campaign.jobs.size();
  s.runner_active = runner_active(paths.dir);
  // Results under keys no job has any more, by label: what a changed input left behind.
  std::set<std::string> current;
  for (const CampaignJob& job : campaign.jobs) current.insert(job.key);
  std::map<std::string, const ResultsStore::Summary*> old_by_label;
  for (const auto& [key, summary] : recorded)
    if (!current.count(key)) {
      const ResultsStore::Summary*& slot = old_by_label[summary.label];
      if (!slot || summary.finished_at > slot->finished_at) slot = &summary;
    }
  auto what_changed = [&](const CampaignJob& job, const ResultsStore::Summary& old) {
    std::vector<std::string> changes;
    if (old.revision != campaign.revision) changes.push_back("the binary (revision " + old.revision + " then)");
    const json& then = old.job;
    auto differs = [&](const char* field) {
      return !then.is_object() || then.value(field, std::string()) != job.resolved.value(field, std::string());
    };
    if (differs("scene_files_hash")) changes.push_back("the scene's files");
    if (differs("preset_file_hash")) changes.push_back("the hardware file");
    if (changes.empty()) changes.push_back("the job's configuration");
    std::string text;
    for (const std::string& c : changes) text += (text.empty() ? "" : " and ") + c;
    return text + " changed since its result of " + old.finished_at;
  };
  for (const CampaignJob& job : campaign.jobs) {
    auto it = recorded.find(job.key);
    if (it == recorded.end()) {
      ++s.missing;
      auto old = old_by_label.find(job.label);
      if (old != old_by_label.end()) s.outdated.emplace_back(job.label, what_changed(job, *old->second));
      // Started (its folder exists) but no result yet: running, or cut short.
      if (fs::exists(paths.job_dir(job.key) / "log.txt") &&
          !fs::exists(paths.result_file(job.key)))
        ++s.started;
    } else if (it->second.status == "ok") {
      ++s.ok;
    } else {
      ++s.failed;
      s.failures.emplace_back(job.label, it->second.error);
    }
  }
  return s;
}

void write_campaign_csv(const Campaign& campaign, const ResultsStore& store, std::ostream& out) {
  auto csv = [](const json& v) -> std::string {
    if (v.is_null()) return "";
    if (v.is_number()) return v.dump();
    std::string t = v.is_string() ? v.get<std::string>() : v.dump();
    if (t.find_first_of(",\"\n\r") == std::string::npos) return t;
    std::string q = "\"";
    for (char c : t) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
  };
  std::vector<std::string> columns = {"campaign", "job_key", "label", "group_name", "config_hash",
                                      "git_revision", "status", "error", "host_seconds",
                                      "finished_at", "scene", "builder", "camera", "preset",
                                      "fidelity", "seed", "overrides"};
  for (const auto& [name, unit] : ResultsStore::headline_columns()) columns.push_back(name);
  for (size_t i = 0; i < columns.size(); ++i) out << (i ? "," : "") << columns[i];
  out << "\n";
  std::set<std::string> keys;
  for (const CampaignJob& j : campaign.jobs) keys.insert(j.key);
  for (const json& row : store.rows(campaign.name)) {
    if (!keys.count(row["job_key"].get<std::string>())) continue;  // stale revision
    for (size_t i = 0; i < columns.size(); ++i)
      out << (i ? "," : "") << csv(row.value(columns[i], json()));
    out << "\n";
  }
}

namespace {

std::vector<const CampaignJob*> jobs_to_emit(const Campaign& campaign, const ResultsStore& store,
                                             const EmitOptions& options) {
  const auto recorded = store.summaries(campaign.name);
  std::vector<const CampaignJob*> out;
  for (const CampaignJob& job : campaign.jobs) {
    auto it = recorded.find(job.key);
    if (!options.all && it != recorded.end() &&
        (it->second.status == "ok" || !options.retry_failed))
      continue;
    out.push_back(&job);
  }
  return out;
}

std::string job_command(const Campaign& campaign, const CampaignPaths& paths,
                        const EmitOptions& options, const std::string& key_word) {
  const fs::path runner = options.runner.empty() ? self_executable() : options.runner;
  std::string cmd = shell_quote(runner.string()) + " campaign job " +
                    shell_quote(campaign.file.string()) + " --key " + key_word + " --out-dir " +
                    shell_quote(paths.dir.string());
  if (!options.binary.empty() && options.binary != runner)
    cmd += " --rtsim " + shell_quote(options.binary.string());
  if (options.timeout_seconds > 0)
    cmd += " --timeout " + json(options.timeout_seconds).dump();
  if (options.no_tree_cache) cmd += " --no-tree-cache";
  return cmd;
}

}  // namespace

fs::path emit_slurm(const Campaign& campaign, const CampaignPaths& paths, const ResultsStore& store,
                    const EmitOptions& options, size_t& count) {
  const fs::path runner = options.runner.empty() ? self_executable() : options.runner;
  const auto jobs = jobs_to_emit(campaign, store, options);
  count = jobs.size();
  const fs::path folder = paths.dir / "slurm";
  fs::create_directories(folder / "logs");
  std::string keys;
  for (const CampaignJob* j : jobs) keys += j->key + "\n";
  write_file_atomic(folder / "jobs.txt", keys);
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# rtsim campaign '" << campaign.name << "': " << count << " jobs as one Slurm array.\n"
    << "# Submit: sbatch " << (folder / "campaign.sbatch").string() << "\n"
    << "# Then:   " << shell_quote(runner.string()) << " campaign collect "
    << shell_quote(campaign.file.string()) << " --out-dir " << shell_quote(paths.dir.string())
    << "\n"
    << "#SBATCH --job-name=rtsim-" << campaign.name << "\n"
    << "#SBATCH --array=0-" << (count == 0 ? 0 : count - 1) << "%" << std::max(1, options.throttle)
    << "\n"
    << "#SBATCH --ntasks=1\n"
    << "#SBATCH --cpus-per-task=1\n"
    << "#SBATCH --output=" << (folder / "logs" / "%A_%a.out").string() << "\n";
  for (const std::string& o : options.sbatch_options) s << "#SBATCH " << o << "\n";
  s << "set -euo pipefail\n"
    << "key=$(sed -n \"$((SLURM_ARRAY_TASK_ID + 1))p\" " << shell_quote((folder / "jobs.txt").string())
    << ")\n"
    << "test -n \"$key\" || { echo \"no job for array index $SLURM_ARRAY_TASK_ID\" >&2; exit 2; }\n"
    << "exec " << job_command(campaign, paths, options, "\"$key\"") << "\n";
  const fs::path script = folder / "campaign.sbatch";
  write_file_atomic(script, s.str());
  fs::permissions(script, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                  fs::perm_options::add);
  return script;
}

fs::path emit_parallel(const Campaign& campaign, const CampaignPaths& paths,
                       const ResultsStore& store, const EmitOptions& options, size_t& count) {
  const auto jobs = jobs_to_emit(campaign, store, options);
  count = jobs.size();
  const fs::path folder = paths.dir / "parallel";
  fs::create_directories(folder);
  std::string lines;
  for (const CampaignJob* j : jobs)
    lines += job_command(campaign, paths, options, j->key) + "\n";
  const fs::path list = folder / "jobs.txt";
  write_file_atomic(list, lines);
  return list;
}

}  // namespace rtsim
