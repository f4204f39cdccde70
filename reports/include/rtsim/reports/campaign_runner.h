#pragma once
// Running a campaign: every job is a separate `rtsim simulate` process (SystemC allows
// one elaboration per process). Each finished job writes a result file
// (DIR/results/<key>.json, atomically) and then one transaction into the results
// store, so a runner killed at any moment (kill -9 included) resumes by running only
// the jobs with neither. The same per-job result files are what Slurm array tasks and
// GNU parallel jobs write; `collect` merges them into the store idempotently.
#include <rtsim/reports/child_process.h>
#include <rtsim/reports/campaign.h>
#include <rtsim/reports/results_store.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace rtsim {

// Where a campaign keeps its work: DIR/jobs/<key>/ (config.json, stats.json, log.txt),
// DIR/results/<key>.json, DIR/slurm/, DIR/parallel/, DIR/run.lock; the database.
struct CampaignPaths {
  std::filesystem::path dir;
  std::filesystem::path database;
  std::filesystem::path job_dir(const std::string& key) const { return dir / "jobs" / key; }
  std::filesystem::path result_file(const std::string& key) const {
    return dir / "results" / (key + ".json");
  }
};
// Defaults: dir = ./rtsim-campaigns/<name>, database = dir/results.sqlite. Absolute paths.
CampaignPaths campaign_paths(const Campaign& campaign, const std::filesystem::path& dir_option,
                             const std::filesystem::path& database_option);

// The revision a binary reports: the text in parentheses of `BINARY --version`
// ("0.1.0 (abc123)" -> "abc123"), else the whole first line. Throws InputError
// naming the binary if it cannot be run.
std::string binary_revision(const std::filesystem::path& binary);

struct RunOptions {
  int parallel = 1;            // jobs at once
  bool retry_failed = false;   // rerun jobs recorded as failed
  bool force = false;          // rerun every job, finished or not
  std::filesystem::path binary;  // the rtsim that runs `simulate` (default: self_executable())
  double timeout_seconds = 0;  // per job, 0 = none; a job over it is killed and recorded failed
  bool progress = false;       // live one-line progress on stderr
  std::vector<std::string> only_keys;  // non-empty: run just these jobs
  // Built trees shared by content hash across jobs and campaigns (empty: every job
  // builds its own). A job's tree is built once by `rtsim build --out` under a file
  // lock, then every job needing it runs `simulate --bvh`.
  std::filesystem::path tree_cache;
  // Finished runs shared across campaigns (empty: none), by content: the job key (a
  // hash of everything the run depends on and the binary's revision, campaign.h) and
  // the job binary's own content (a binary rebuilt at the same revision is another
  // simulator). An ok result stored under them is that job's result in any campaign:
  // a missing job found here is recorded from it instead of run again, and every job
  // that runs ok is stored here.
  std::filesystem::path results_cache;
};

// Where the results cache keeps a job's result: <cache>/<job key>-<binary hash>.json.
std::filesystem::path cached_result(const std::filesystem::path& cache, const std::string& job_key,
                                    const std::string& binary_hash);

// The tree a job replays from the cache: <cache>/<hash of scene, builder, camera, seed,
// revision>.bvh.
std::filesystem::path cached_tree(const std::filesystem::path& cache, const Campaign& campaign,
                                  const CampaignJob& job);

struct RunSummary {
  size_t total = 0, already_ok = 0, skipped_failed = 0, ran = 0, ok = 0, failed = 0;
  size_t reused = 0;     // recorded from the results cache, not run
  size_t collected = 0;  // result files merged before running (a previous run's leftovers)
  double wall_seconds = 0;
  bool interrupted = false;
};

// Runs the campaign's missing jobs. Throws InputError if another runner holds the
// campaign's lock. SIGINT/SIGTERM stop the children and return with interrupted set.
RunSummary run_campaign(const Campaign& campaign, const CampaignPaths& paths,
                        const RunOptions& options);

// Runs one job in the foreground and writes its result file; no database access (a
// Slurm or GNU parallel task on another machine). A result file that is already "ok"
// makes this a no-op unless `force`.
RunRecord run_one_job(const Campaign& campaign, const CampaignJob& job, const CampaignPaths& paths,
                      const std::filesystem::path& binary, double timeout_seconds, bool force,
                      const std::filesystem::path& tree_cache = {});

struct CollectSummary {
  size_t files = 0, inserted = 0, replaced = 0, unchanged = 0, kept_ok = 0, stale = 0, bad = 0;
  std::vector<std::string> problems;  // "file: reason" for bad and stale files
};
// Merges DIR/results/*.json of this campaign into the store. Idempotent.
CollectSummary collect_results(const Campaign& campaign, const CampaignPaths& paths,
                               ResultsStore& store);

struct CampaignStatus {
  size_t total = 0, ok = 0, failed = 0, missing = 0;
  // Missing jobs with an output folder but no result: running if a runner holds the
  // campaign's lock (or on Slurm / GNU parallel), else cut short by a kill.
  size_t started = 0;
  bool runner_active = false;
  std::vector<std::pair<std::string, std::string>> failures;  // label, error
  // Missing jobs that have a result under an older key: their inputs changed since
  // (label, what changed and when the old result was made). Counted in `missing`.
  std::vector<std::pair<std::string, std::string>> outdated;
};
CampaignStatus campaign_status(const Campaign& campaign, const CampaignPaths& paths,
                               const ResultsStore& store);

// CSV of the campaign's rows: identity, job axes, status and headline columns.
void write_campaign_csv(const Campaign& campaign, const ResultsStore& store, std::ostream& out);

struct EmitOptions {
  std::filesystem::path runner;  // rtsim running `campaign job` on the nodes (default: this one)
  std::filesystem::path binary;  // rtsim running each job's `simulate` (default: the runner)
  int throttle = 8;              // Slurm array tasks at once (%N)
  bool retry_failed = false;     // also list jobs recorded as failed
  bool all = false;              // list every job, finished or not
  std::vector<std::string> sbatch_options;  // extra "#SBATCH" lines, e.g. "--partition=x"
  double timeout_seconds = 0;
  bool no_tree_cache = false;    // the tasks build their own trees
};
// DIR/slurm/campaign.sbatch + DIR/slurm/jobs.txt; returns the sbatch script path and
// fills `count` with the number of array tasks (0: nothing left to run).
std::filesystem::path emit_slurm(const Campaign& campaign, const CampaignPaths& paths,
                                 const ResultsStore& store, const EmitOptions& options,
                                 size_t& count);
// DIR/parallel/jobs.txt (one shell command per line); returns its path.
std::filesystem::path emit_parallel(const Campaign& campaign, const CampaignPaths& paths,
                                    const ResultsStore& store, const EmitOptions& options,
                                    size_t& count);


}  // namespace rtsim
