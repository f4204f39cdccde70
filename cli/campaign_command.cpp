// rtsim campaign run|status|list|export|emit|collect|job
#include "rtsim_revision.h"
#include "cli_util.h"
#include "commands.h"

#include <cstdlib>
#include <rtsim/reports/campaign.h>
#include <rtsim/reports/campaign_runner.h>
#include <rtsim/reports/results_store.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/progress.h>
#include <rtsim/workloads/scene_registry.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

namespace rtsim::cli {

namespace {

namespace fs = std::filesystem;

// Options every campaign subcommand shares.
struct CampaignArgs {
  std::string file;
  std::string dir;
  std::string database;
  std::string binary;
  std::string tree_cache, results_cache;
  bool no_tree_cache = false, no_results_cache = false;
};

void add_results_cache(CLI::App* cmd, CampaignArgs& a) {
  cmd->add_option("--results-cache", a.results_cache,
                  "folder of finished runs shared by job key across campaigns\n(default: "
                  "<scene cache>/results when the jobs run this rtsim,\nor $RTSIM_RESULTS_CACHE: "
                  "a folder or 'off')");
  cmd->add_flag("--no-results-cache", a.no_results_cache, "run every missing job, even one another campaign ran");
}

// As the tree cache: on by default only for this rtsim's own jobs.
// RTSIM_RESULTS_CACHE (a folder, or "off") replaces the default, so a test suite or a
// benchmark can make every campaign run its jobs without passing a flag to each.
// `source` names where the folder came from, for messages about it.
fs::path results_cache_of(const CampaignArgs& a, std::string* source) {
  *source = "--results-cache";
  if (a.no_results_cache) return {};
  if (!a.results_cache.empty()) return fs::absolute(a.results_cache);
  if (!a.binary.empty()) return {};
  if (const char* env = std::getenv("RTSIM_RESULTS_CACHE"); env && *env) {
    *source = "RTSIM_RESULTS_CACHE";
    return std::string(env) == "off" ? fs::path() : fs::absolute(env);
  }
  return scene_cache_dir() / "results";
}

void add_tree_cache(CLI::App* cmd, CampaignArgs& a) {
  cmd->add_option("--tree-cache", a.tree_cache,
                  "folder of built trees shared across jobs and campaigns\n(default: "
                  "<scene cache>/trees when the jobs run this rtsim)");
  cmd->add_flag("--no-tree-cache", a.no_tree_cache, "every job builds its own tree");
}

// Trees are shared only when the job binary is known to have `build` and
// `simulate --bvh`: this rtsim, or any binary given with an explicit --tree-cache.
fs::path tree_cache_of(const CampaignArgs& a) {
  if (a.no_tree_cache) return {};
  if (!a.tree_cache.empty()) return fs::absolute(a.tree_cache);
  if (!a.binary.empty()) return {};
  return scene_cache_dir() / "trees";
}

void add_common(CLI::App* cmd, CampaignArgs& a) {
  cmd->add_option("file", a.file, "campaign file (.toml or .json)")->required();
  cmd->add_option("--out-dir", a.dir,
                  "the campaign's folder: job outputs, result files, the database\n"
                  "(default: rtsim-campaigns/<campaign name> beside the campaign file)");
  add_deprecated_option(cmd, "--dir", "--out-dir", a.dir);
  cmd->add_option("--db", a.database, "results database (default: <dir>/results.sqlite)");
  cmd->add_option("--rtsim", a.binary,
                  "the rtsim binary that runs each job's `simulate` (default: this one)");
}

fs::path job_binary(const CampaignArgs& a) {
  return a.binary.empty() ? self_executable() : fs::absolute(a.binary);
}

Campaign load(const CampaignArgs& a) {
  // This binary knows its revision; another one is asked (`--version`).
  const std::string revision = a.binary.empty() ? std::string(RTSIM_GIT_REVISION)
                                                : binary_revision(job_binary(a));
  return load_campaign(a.file, revision);
}

CampaignPaths paths_of(const Campaign& c, const CampaignArgs& a) {
  return campaign_paths(c, a.dir, a.database);
}

void print_collect(const CollectSummary& s, bool verbose) {
  std::printf("collected %zu result files: %zu new, %zu replaced, %zu unchanged, %zu kept "
              "(an ok run is not replaced by a failure), %zu stale, %zu unreadable\n",
              s.files, s.inserted, s.replaced, s.unchanged, s.kept_ok, s.stale, s.bad);
  if (verbose)
    for (const std::string& p : s.problems) std::fprintf(stderr, "  %s\n", p.c_str());
}

// campaign run: the missing jobs, one process each, resumable
void add_run_subcommand(CLI::App* campaign) {
  auto a = std::make_shared<CampaignArgs>();
  auto parallel = std::make_shared<int>(1);
  auto retry_failed = std::make_shared<bool>(false);
  auto force = std::make_shared<bool>(false);
  auto timeout = std::make_shared<double>(0);
  auto json_out = std::make_shared<bool>(false);
  CLI::App* cmd = campaign->add_subcommand(
      "run", "run the campaign's missing jobs, one process each; resumable at any moment");
  cmd->add_flag("--json", *json_out, "print the summary as JSON");
  add_common(cmd, *a);
  cmd->add_option("-j,--jobs", *parallel, "jobs at once")->check(CLI::Range(1, 1024));
  add_tree_cache(cmd, *a);
  add_results_cache(cmd, *a);
  cmd->add_flag("--retry-failed", *retry_failed, "rerun jobs recorded as failed");
  cmd->add_flag("--force", *force, "rerun every job, even finished ones");
  cmd->add_option("--timeout", *timeout, "seconds per job before it is killed (0: none)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([=] {
    const Campaign c = load(*a);
    const CampaignPaths paths = paths_of(c, *a);
    // Every path the run writes, before the first job (they failed as "internal
    // error: filesystem error" once jobs were under way).
    check_output_folder(paths.dir, "--out-dir");
    check_output_file(paths.database, "--db");
    RunOptions o;
    o.parallel = *parallel;
    o.retry_failed = *retry_failed;
    o.force = *force;
    o.binary = job_binary(*a);
    o.timeout_seconds = *timeout;
    o.progress = Progress::enabled();
    o.tree_cache = usable_tree_cache(tree_cache_of(*a), "--tree-cache");
    std::string results_source;
    const fs::path results_cache = results_cache_of(*a, &results_source);
    o.results_cache = usable_tree_cache(results_cache, results_source, "results cache", "every missing job runs");
    const RunSummary s = run_campaign(c, paths, o);
    ResultsStore store(paths.database, ResultsStore::Access::ReadOnly);
    const CampaignStatus st = campaign_status(c, paths, store);
    if (*json_out) {
      nlohmann::json j = {{"campaign", c.name},        {"jobs", s.total},       {"ran", s.ran},
                          {"reused", s.reused},
                          {"ran_ok", s.ok},            {"ran_failed", s.failed}, {"seconds", s.wall_seconds},
                          {"ok", st.ok},               {"failed", st.failed},   {"missing", st.missing},
                          {"skipped_failed", s.skipped_failed}, {"interrupted", s.interrupted},
                          {"database", paths.database.string()}, {"failures", nlohmann::json::array()}};
      for (const auto& [label, error] : st.failures)
        j["failures"].push_back({{"label", label}, {"reason", error.substr(0, error.find('\n'))}});
      std::cout << j.dump(2) << "\n";
    } else {
      std::printf("campaign %s: %zu jobs; ran %zu (%zu ok, %zu failed) in %.1f s%s; "
                  "%zu ok, %zu failed, %zu missing; results in %s\n",
                  c.name.c_str(), s.total, s.ran, s.ok, s.failed, s.wall_seconds,
                  s.reused ? (", " + std::to_string(s.reused) + " reused from the results cache").c_str() : "",
                  st.ok, st.failed, st.missing, paths.database.string().c_str());
      for (const auto& [label, error] : st.failures)
        std::printf("  failed %s: %s\n", label.c_str(), error.substr(0, error.find('\n')).c_str());
      if (s.skipped_failed)
        std::printf("%zu failed jobs were not rerun (use --retry-failed)\n", s.skipped_failed);
    }
    if (s.interrupted) throw ExitStatus(130, "interrupted; run again to resume");
    // A job that failed in this run fails the run, even where an older ok result
    // of it is kept (--force): the run did not do what it was asked.
    if (st.failed || s.failed)
      throw ExitStatus(1, std::to_string(s.failed) + " of the " + std::to_string(s.ran) +
                              " jobs run failed; " + std::to_string(st.failed) + " jobs are recorded as failed");
  });
}

// campaign status: counts, failures and outdated jobs, read-only
void add_status_subcommand(CLI::App* campaign) {
  auto a = std::make_shared<CampaignArgs>();
  auto json_out = std::make_shared<bool>(false);
  CLI::App* cmd = campaign->add_subcommand(
      "status", "jobs done, failed, running and missing (reads the database, never writes it)");
  add_common(cmd, *a);
  cmd->add_flag("--json", *json_out, "print the counts, failures and outdated jobs as JSON");
  cmd->callback([=] {
    const Campaign c = load(*a);
    const CampaignPaths paths = paths_of(c, *a);
    ResultsStore store(paths.database, ResultsStore::Access::ReadOnly);
    const CampaignStatus s = campaign_status(c, paths, store);
    if (*json_out) {
      nlohmann::json j = {{"campaign", c.name}, {"revision", c.revision}, {"jobs", s.total},
                          {"ok", s.ok},         {"failed", s.failed},     {"missing", s.missing},
                          {"started", s.started}, {"runner_active", s.runner_active},
                          {"database", paths.database.string()},
                          {"failures", nlohmann::json::array()}, {"outdated", nlohmann::json::array()}};
      for (const auto& [label, error] : s.failures)
        j["failures"].push_back({{"label", label}, {"reason", error.substr(0, error.find('\n'))}});
      for (const auto& [label, why] : s.outdated) j["outdated"].push_back({{"label", label}, {"why", why}});
      std::cout << j.dump(2) << "\n";
      return;
    }
    std::printf("campaign %s (revision %s): %zu jobs: %zu ok, %zu failed, %zu missing\n",
                c.name.c_str(), c.revision.c_str(), s.total, s.ok, s.failed, s.missing);
    if (s.runner_active)
      std::printf("a `campaign run` is active: %zu running, %zu left to start\n", s.started,
                  s.missing - s.started);
    else if (s.started)
      std::printf("%zu jobs started without a result (a run was stopped, or they are running "
                  "on Slurm / GNU parallel)\n", s.started);
    for (const auto& [label, error] : s.failures)
      std::printf("  failed %s: %s\n", label.c_str(), error.substr(0, error.find('\n')).c_str());
    if (!s.outdated.empty())
      std::printf("%zu of the missing jobs have an older result that no longer counts:\n", s.outdated.size());
    for (const auto& [label, why] : s.outdated) std::printf("  outdated %s: %s\n", label.c_str(), why.c_str());
  });
}

// campaign list: the expanded jobs
void add_list_subcommand(CLI::App* campaign) {
  auto a = std::make_shared<CampaignArgs>();
  auto json_out = std::make_shared<bool>(false);
  CLI::App* cmd = campaign->add_subcommand("list", "the expanded jobs: key, group, label");
  add_common(cmd, *a);
  cmd->add_flag("--json", *json_out,
                "the resolved jobs as JSON: key, label, simulate's arguments\n(DIR = the job's "
                "output folder) and the hardware file the runner writes there");
  cmd->callback([=] {
    const Campaign c = load(*a);
    if (*json_out) {
      nlohmann::json all = nlohmann::json::array();
      for (const CampaignJob& j : c.jobs)
        all.push_back({{"key", j.key}, {"config_hash", j.config_hash}, {"group", j.group},
                       {"label", j.label}, {"resolved", j.resolved},
                       {"hardware_toml", j.hardware_toml},
                       {"arguments", j.hardware_toml.empty()
                                         ? j.simulate_arguments("DIR")
                                         : j.simulate_arguments("DIR", "DIR/hardware.toml")}});
      std::cout << all.dump(2) << "\n";
      return;
    }
    for (const CampaignJob& j : c.jobs)
      std::printf("%s  %-12s %s\n", j.key.c_str(), j.group.c_str(), j.label.c_str());
  });
}

// campaign export: the results as CSV
void add_export_subcommand(CLI::App* campaign) {
  auto a = std::make_shared<CampaignArgs>();
  auto out = std::make_shared<std::string>();
  CLI::App* cmd = campaign->add_subcommand("export", "the results as CSV");
  add_common(cmd, *a);
  // Unbound: CSV is the one format so far, so nothing needs to keep its value.
  cmd->add_flag("--csv", "comma-separated values (the one format so far)")->required();
  cmd->add_option("--out", *out, "file to write (default: standard output)");
  add_deprecated_option(cmd, "-o,--output", "--out", *out);
  cmd->callback([=] {
    if (!out->empty()) check_output_file(*out, "--out");
    const Campaign c = load(*a);
    ResultsStore store(paths_of(c, *a).database, ResultsStore::Access::ReadOnly);
    std::ostringstream text;
    write_campaign_csv(c, store, text);
    if (out->empty()) std::cout << text.str();
    else write_file_atomic(*out, text.str());
  });
}

// campaign emit: a Slurm job array or a GNU parallel job list
void add_emit_subcommand(CLI::App* campaign) {
  auto a = std::make_shared<CampaignArgs>();
  auto slurm = std::make_shared<bool>(false);
  auto parallel = std::make_shared<bool>(false);
  auto o = std::make_shared<EmitOptions>();
  CLI::App* cmd = campaign->add_subcommand(
      "emit", "write a Slurm job array or a GNU parallel job list for the missing jobs");
  add_common(cmd, *a);
  auto* s = cmd->add_flag("--slurm", *slurm, "an sbatch job-array script");
  auto* p = cmd->add_flag("--parallel", *parallel, "a GNU parallel job list");
  s->excludes(p);
  cmd->add_option("--throttle", o->throttle, "Slurm array tasks running at once")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--sbatch-option", o->sbatch_options,
                  "extra #SBATCH line, e.g. --sbatch-option=--partition=short (repeatable)")
      ->allow_extra_args(false);
  cmd->add_option("--runner", o->runner,
                  "the rtsim that runs `campaign job` on the compute nodes (default: this one)");
  cmd->add_flag("--retry-failed", o->retry_failed, "also list jobs recorded as failed");
  cmd->add_flag("--all", o->all, "list every job, finished or not");
  cmd->add_flag("--no-tree-cache", o->no_tree_cache,
                "tasks build their own trees (use when nodes share no cache folder)");
  cmd->add_option("--timeout", o->timeout_seconds, "seconds per job (0: none)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([=] {
    if (!*slurm && !*parallel) throw InputError("campaign emit", "choose --slurm or --parallel");
    // Each option is one #SBATCH line: a line break would start a line of the script.
    for (const std::string& option : o->sbatch_options)
      if (option.find_first_of("\n\r") != std::string::npos)
        throw InputError("--sbatch-option", "must be one line; '" + option.substr(0, option.find_first_of("\n\r")) +
                                                "...' holds a line break");
    const Campaign c = load(*a);
    const CampaignPaths paths = paths_of(c, *a);
    check_output_folder(paths.dir, "--out-dir");
    ResultsStore store(paths.database, ResultsStore::Access::ReadOnly);
    if (!a->binary.empty()) o->binary = job_binary(*a);
    const fs::path runner = o->runner.empty() ? self_executable() : o->runner;
    size_t count = 0;
    const std::string collect = shell_quote(runner.string()) + " campaign collect " +
                                shell_quote(c.file.string()) + " --out-dir " +
                                shell_quote(paths.dir.string()) +
                                (a->database.empty() ? "" : " --db " + shell_quote(paths.database.string())) +
                                (a->binary.empty() ? "" : " --rtsim " + shell_quote(o->binary.string()));
    if (*slurm) {
      const fs::path script = emit_slurm(c, paths, store, *o, count);
      std::printf("%s: %zu array tasks\n", script.string().c_str(), count);
      if (count) std::printf("submit:  sbatch %s\nthen:    %s\n", shell_quote(script.string()).c_str(), collect.c_str());
    } else {
      const fs::path list = emit_parallel(c, paths, store, *o, count);
      std::printf("%s: %zu jobs\n", list.string().c_str(), count);
      if (count)
        std::printf("run:   parallel --jobs N --joblog %s --resume < %s\nthen:  %s\n",
                    shell_quote((list.parent_path() / "joblog.txt").string()).c_str(),
                    shell_quote(list.string()).c_str(), collect.c_str());
    }
  });
}

// campaign collect: per-job result files into the database
void add_collect_subcommand(CLI::App* campaign) {
  auto a = std::make_shared<CampaignArgs>();
  auto json_out = std::make_shared<bool>(false);
  CLI::App* cmd = campaign->add_subcommand(
      "collect", "merge per-job result files (Slurm, GNU parallel) into the database");
  add_common(cmd, *a);
  cmd->add_flag("--json", *json_out, "print the counts and problems as JSON");
  cmd->callback([=] {
    const Campaign c = load(*a);
    const CampaignPaths paths = paths_of(c, *a);
    check_output_file(paths.database, "--db");
    ResultsStore store(paths.database);
    const CollectSummary s = collect_results(c, paths, store);
    if (*json_out)
      std::cout << nlohmann::json{{"files", s.files},         {"new", s.inserted},  {"replaced", s.replaced},
                                  {"unchanged", s.unchanged}, {"kept_ok", s.kept_ok}, {"stale", s.stale},
                                  {"unreadable", s.bad},      {"problems", s.problems}}
                       .dump(2)
                << "\n";
    else
      print_collect(s, true);
    if (s.bad) throw ExitStatus(1, std::to_string(s.bad) + " result files could not be read");
  });
}

// campaign job: one job by key (what an array task or a GNU parallel line runs)
void add_job_subcommand(CLI::App* campaign) {
  auto a = std::make_shared<CampaignArgs>();
  auto key = std::make_shared<std::string>();
  auto force = std::make_shared<bool>(false);
  auto timeout = std::make_shared<double>(0);
  auto json_out = std::make_shared<bool>(false);
  CLI::App* cmd = campaign->add_subcommand(
      "job", "run one job by key and write its result file (no database access)");
  cmd->add_flag("--json", *json_out, "print the job's result record as JSON");
  add_common(cmd, *a);
  cmd->add_option("--key", *key, "the job key (`rtsim campaign list`)")->required();
  add_tree_cache(cmd, *a);
  cmd->add_flag("--force", *force, "rerun even if its result file says ok");
  cmd->add_option("--timeout", *timeout, "seconds before the job is killed (0: none)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([=] {
    const Campaign c = load(*a);
    const CampaignJob* job = c.find(*key);
    if (!job)
      throw InputError("--key " + *key, "no job with this key in " + c.file.string() +
                                            " at revision " + c.revision);
    const CampaignPaths paths = paths_of(c, *a);
    check_output_folder(paths.dir, "--out-dir");
    const RunRecord r = run_one_job(c, *job, paths, job_binary(*a), *timeout, *force,
                                    usable_tree_cache(tree_cache_of(*a), "--tree-cache"));
    if (*json_out)
      std::cout << r.to_json().dump(2) << "\n";
    else
      std::printf("%s %s %s (%.2f s)\n", r.job_key.c_str(), r.status.c_str(), r.label.c_str(),
                  r.host_seconds);
    if (r.status != "ok") throw ExitStatus(1, "job failed: " + r.error);
  });
}
}  // namespace

void add_campaign_command(CLI::App& root) {
  CLI::App* campaign = root.add_subcommand(
      "campaign", "declarative sweeps of simulations: run, status, export, Slurm/GNU parallel");
  campaign->require_subcommand(1);

  add_run_subcommand(campaign);
  add_status_subcommand(campaign);
  add_list_subcommand(campaign);
  add_export_subcommand(campaign);
  add_emit_subcommand(campaign);
  add_collect_subcommand(campaign);
  add_job_subcommand(campaign);
}

}  // namespace rtsim::cli
