// `rtsim campaign` end to end over a fake simulator: run, rerun as a no-op, failed jobs
// and --retry-failed, per-job result files + idempotent collect (the Slurm / GNU
// parallel path) giving the same database as a local run, CSV export.
#include "integration/test_campaign_fake.h"

#include <rtsim/reports/campaign.h>
#include <rtsim/reports/campaign_report.h>
#include <rtsim/reports/campaign_runner.h>
#include <rtsim/reports/plot_script.h>
#include <rtsim/reports/results_store.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace rtsim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::read_lines;
using test::shell;

struct Fixture {
  fs::path dir, fake, campaign, log;
  std::string rtsim(const std::string& args, const std::string& env = "") const {
    return env + " FAKE_LOG=" + shell_quote(log.string()) + " " + shell_quote(RTSIM_BINARY) +
           " " + args + " --rtsim " + shell_quote(fake.string()) + " >" +
           shell_quote((dir / "out.txt").string()) + " 2>" + shell_quote((dir / "err.txt").string());
  }
  std::string work(const std::string& name) const { return " --out-dir " + shell_quote((dir / name).string()); }
};

Fixture make_fixture(const std::string& tag, int seeds) {
  Fixture f;
  f.dir = test::fresh_folder(tag);
  f.fake = test::write_fake_rtsim(f.dir);
  f.campaign = test::write_text(f.dir / "c.toml", test::small_campaign("demo", seeds));
  f.log = f.dir / "fake.log";
  return f;
}

// Deterministic columns: everything but host time and timestamps.
std::vector<json> comparable_rows(const fs::path& db) {
  ResultsStore store(db);
  std::vector<json> rows = store.rows("demo");
  for (json& r : rows) {
    for (const char* k : {"host_seconds", "finished_at", "record_hash"}) r.erase(k);
  }
  return rows;
}

TEST(CampaignRun, RunsEveryJobOnceAndARerunIsANoOp) {
  const Fixture f = make_fixture("run", 3);  // 2 builders x 2 presets x 3 seeds
  ASSERT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + " -j 3" + f.work("w"))), 0)
      << test::read_lines(f.dir / "err.txt").size();
  EXPECT_EQ(read_lines(f.log).size(), 12u);
  const auto first = comparable_rows(f.dir / "w" / "results.sqlite");
  ASSERT_EQ(first.size(), 12u);
  for (const json& r : first) {
    EXPECT_EQ(r["status"], "ok");
    EXPECT_EQ(r["git_revision"], "fakerev1");
    EXPECT_TRUE(r["ops_per_ray"].is_number());
    EXPECT_TRUE(r["l1_node_hit_rate"].is_number());
    EXPECT_TRUE(fs::exists(f.dir / "w" / "jobs" / r["job_key"].get<std::string>() / "stats.json"));
  }
  // Not a terminal: quiet except the one summary line.
  EXPECT_EQ(read_lines(f.dir / "out.txt").size(), 1u);

  ASSERT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + " -j 2" + f.work("w"))), 0);
  EXPECT_EQ(read_lines(f.log).size(), 12u);  // nothing ran again
  EXPECT_EQ(comparable_rows(f.dir / "w" / "results.sqlite"), first);

  // A new binary revision makes new jobs.
  ASSERT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + f.work("w"),
                          "FAKE_REVISION=fakerev2")), 0);
  EXPECT_EQ(read_lines(f.log).size(), 24u);

  // status and export see the same campaign.
  ASSERT_EQ(shell(f.rtsim("campaign status " + f.campaign.string() + f.work("w"))), 0);
  const auto status = read_lines(f.dir / "out.txt");
  ASSERT_FALSE(status.empty());
  EXPECT_NE(status[0].find("12 jobs: 12 ok, 0 failed, 0 missing"), std::string::npos) << status[0];
  ASSERT_EQ(shell(f.rtsim("campaign export --csv " + f.campaign.string() + f.work("w"))), 0);
  const auto csv = read_lines(f.dir / "out.txt");
  ASSERT_EQ(csv.size(), 13u);
  EXPECT_EQ(csv[0].rfind("campaign,job_key,label,", 0), 0u);
}

TEST(CampaignRun, FailedJobsAreRecordedAndRetriedOnlyOnRequest) {
  const Fixture f = make_fixture("fail", 1);
  EXPECT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + f.work("w"),
                          "FAKE_FAIL_BUILDER=aobvh")), 1);
  EXPECT_EQ(read_lines(f.log).size(), 4u);
  {
    ResultsStore store(f.dir / "w" / "results.sqlite");
    size_t failed = 0;
    for (const json& r : store.rows("demo")) {
      if (r["builder"] == "aobvh") {
        ++failed;
        EXPECT_EQ(r["status"], "failed");
        EXPECT_NE(r["error"].get<std::string>().find("exit code 3"), std::string::npos);
        EXPECT_NE(r["error"].get<std::string>().find("refused on purpose"), std::string::npos);
      } else {
        EXPECT_EQ(r["status"], "ok");
      }
    }
    EXPECT_EQ(failed, 2u);
  }
  // Without --retry-failed nothing runs (and the exit status still reports failures).
  EXPECT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + f.work("w"))), 1);
  EXPECT_EQ(read_lines(f.log).size(), 4u);
  // With it, exactly the failed jobs run.
  EXPECT_EQ(shell(f.rtsim("campaign run --retry-failed " + f.campaign.string() + f.work("w"))), 0);
  EXPECT_EQ(read_lines(f.log).size(), 6u);
  ResultsStore store(f.dir / "w" / "results.sqlite");
  for (const json& r : store.rows("demo")) EXPECT_EQ(r["status"], "ok");
}

// The scale-out path: every job run by `campaign job` (what a Slurm array task or a GNU
// parallel line does), then `campaign collect`, twice. The database equals a local run's.
TEST(CampaignRun, CollectIsIdempotentAndMatchesALocalRun) {
  const Fixture f = make_fixture("collect", 2);
  ASSERT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + " -j 2" + f.work("local"))), 0);

  ASSERT_EQ(shell(f.rtsim("campaign emit --parallel " + f.campaign.string() + f.work("remote"))), 0);
  const auto commands = read_lines(f.dir / "remote" / "parallel" / "jobs.txt");
  ASSERT_EQ(commands.size(), 8u);
  for (const std::string& c : commands)
    ASSERT_EQ(shell("FAKE_LOG=" + shell_quote(f.log.string()) + " " + c + " >/dev/null"), 0) << c;
  EXPECT_EQ(read_lines(f.log).size(), 16u);
  // A task rerun after success is a no-op (its result file is ok).
  ASSERT_EQ(shell("FAKE_LOG=" + shell_quote(f.log.string()) + " " + commands[0] + " >/dev/null"), 0);
  EXPECT_EQ(read_lines(f.log).size(), 16u);

  ASSERT_EQ(shell(f.rtsim("campaign collect " + f.campaign.string() + f.work("remote"))), 0);
  const auto once = comparable_rows(f.dir / "remote" / "results.sqlite");
  ASSERT_EQ(shell(f.rtsim("campaign collect " + f.campaign.string() + f.work("remote"))), 0);
  EXPECT_NE(read_lines(f.dir / "out.txt")[0].find("0 new, 0 replaced, 8 unchanged"),
            std::string::npos);
  EXPECT_EQ(comparable_rows(f.dir / "remote" / "results.sqlite"), once);
  EXPECT_EQ(once, comparable_rows(f.dir / "local" / "results.sqlite"));
  {
    ResultsStore store(f.dir / "remote" / "results.sqlite");
    EXPECT_EQ(store.integrity_check(), "ok");
  }
  // Nothing left to emit once everything is collected.
  ASSERT_EQ(shell(f.rtsim("campaign emit --slurm " + f.campaign.string() + f.work("remote"))), 0);
  EXPECT_TRUE(read_lines(f.dir / "remote" / "slurm" / "jobs.txt").empty());
}

TEST(CampaignRun, SlurmScriptIsAThrottledArrayOverTheMissingJobs) {
  const Fixture f = make_fixture("slurm", 2);
  ASSERT_EQ(shell(f.rtsim("campaign emit --slurm --throttle 3 --sbatch-option=--partition=debug " +
                          f.campaign.string() + f.work("w"))), 0);
  const auto keys = read_lines(f.dir / "w" / "slurm" / "jobs.txt");
  EXPECT_EQ(keys.size(), 8u);
  std::ifstream in(f.dir / "w" / "slurm" / "campaign.sbatch");
  const std::string script((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(script.find("#SBATCH --array=0-7%3"), std::string::npos) << script;
  EXPECT_NE(script.find("#SBATCH --partition=debug"), std::string::npos);
  EXPECT_NE(script.find("campaign job"), std::string::npos);
  // bash accepts the script; an array task runs its job when given an index.
  EXPECT_EQ(shell("bash -n " + shell_quote((f.dir / "w" / "slurm" / "campaign.sbatch").string())), 0);
  ASSERT_EQ(shell("SLURM_ARRAY_TASK_ID=5 FAKE_LOG=" + shell_quote(f.log.string()) + " bash " +
                  shell_quote((f.dir / "w" / "slurm" / "campaign.sbatch").string()) + " >/dev/null"),
            0);
  EXPECT_TRUE(fs::exists(f.dir / "w" / "results" / (keys[5] + ".json")));
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(CampaignRun, ReportHasEveryFigureWithCaptionAndTheFailedJobs) {
  if (shell(shell_quote(plot_python()) + " -c 'import matplotlib' 2>/dev/null") != 0)
    GTEST_SKIP() << "python3-matplotlib is not installed for " << plot_python();
  const Fixture f = make_fixture("report", 1);
  test::write_text(f.campaign, test::small_campaign("demo", 1) +
                                   "[[group]]\nname = \"grid\"\n[[group]]\nname = \"l2\"\n"
                                   "builder = \"sah\"\npreset = \"mobile\"\n"
                                   "set.l2.size_bytes = [131072, 262144]\n");
  EXPECT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + f.work("w"),
                          "FAKE_FAIL_BUILDER=aobvh")), 1);
  CampaignReportOptions o;
  o.database = f.dir / "w" / "results.sqlite";
  o.out_dir = f.dir / "report";
  const CampaignReportFiles files = write_campaign_report(o);
  const std::string md = read_all(files.markdown), html = read_all(files.html);
  // DRAM, hit rates, cycles and the l2.size_bytes sweep; not ops/fetches per ray type,
  // which the fake's stats do not have (an empty figure is left out).
  ASSERT_EQ(files.figures.size(), 4u);
  for (const fs::path& png : files.figures) {
    const std::string bytes = read_all(png);
    ASSERT_GT(bytes.size(), 1000u) << png;
    EXPECT_EQ(bytes.substr(1, 3), "PNG") << png;
    EXPECT_NE(md.find("](" + png.filename().string() + ")"), std::string::npos);
    EXPECT_NE(html.find("<img src=\"" + png.filename().string() + "\""), std::string::npos);
  }
  EXPECT_NE(md.find("*Figure 4: "), std::string::npos);
  EXPECT_NE(md.find("## Failed jobs"), std::string::npos);
  EXPECT_NE(md.find("refused on purpose"), std::string::npos);
  // The table has one row per ok run (2 sah + 2 sweep points, aobvh failed); the
  // columns every row shares (scene, builder) are said above it instead.
  const std::string table = md.substr(md.find("## Results"), md.find("## Failed jobs") - md.find("## Results"));
  size_t rows = 0;
  std::istringstream lines(table);
  for (std::string line; std::getline(lines, line);) rows += line.rfind("|", 0) == 0;
  EXPECT_EQ(rows, 4u + 2) << table;  // and the header and its rule
  EXPECT_NE(md.find("Every run: scene interior"), std::string::npos);
  EXPECT_THROW(write_campaign_report({f.dir / "missing.sqlite", f.dir / "r2", "", false}),
               std::exception);
}

// Runs the campaign in DIR/c.toml twice, with a tree cache (DIR/cache) into
// DIR/shared and without into DIR/own; returns the number of cached trees.
size_t run_with_and_without_tree_cache(const fs::path& dir, const std::string& text) {
  const fs::path campaign = test::write_text(dir / "c.toml", text);
  const std::string rtsim = shell_quote(RTSIM_BINARY) + " campaign run " + shell_quote(campaign.string());
  // No results cache: both runs run every job (the first through the tree cache).
  EXPECT_EQ(shell(rtsim + " -j 2 --no-results-cache --out-dir " + shell_quote((dir / "shared").string()) +
                  " --tree-cache " + shell_quote((dir / "cache").string()) + " >/dev/null"), 0);
  EXPECT_EQ(shell(rtsim + " -j 2 --no-tree-cache --no-results-cache --out-dir " + shell_quote((dir / "own").string()) +
                  " >/dev/null"), 0);
  size_t trees = 0;
  if (fs::is_directory(dir / "cache"))
    for (const auto& e : fs::directory_iterator(dir / "cache")) trees += e.path().extension() == ".bvh";
  return trees;
}

// The two runs (shared tree cache, own trees) of campaign `name` have `jobs` rows
// each: the same jobs with byte-identical stats. `shared_rows` gets the first run's.
void same_results_either_way(const fs::path& dir, const std::string& name, size_t jobs,
                             std::vector<json>* shared_rows = nullptr) {
  ResultsStore shared(dir / "shared" / "results.sqlite"), own(dir / "own" / "results.sqlite");
  const auto a = shared.rows(name), b = own.rows(name);
  ASSERT_EQ(a.size(), jobs);
  ASSERT_EQ(b.size(), jobs);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i]["job_key"], b[i]["job_key"]);
    EXPECT_EQ(a[i]["stats_json"], b[i]["stats_json"]) << a[i]["label"];
  }
  if (shared_rows) *shared_rows = a;
}

// With the real simulator: jobs sharing a tree build it once (rtsim build --out into the
// cache, simulate --bvh) and give byte-identical stats to jobs that build their own.
TEST(CampaignRun, SharedTreesAreBuiltOnceAndChangeNoResult) {
  const fs::path dir = test::fresh_folder("trees");
  EXPECT_EQ(run_with_and_without_tree_cache(
                dir, "[campaign]\nname = \"trees\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"sah\"\n"
                     "preset = [\"mobile\", \"desktop\"]\nresolution = \"12x12\"\n"
                     "set.l2.size_bytes = [131072, 262144]\n"),
            1u);  // 4 jobs, one (scene, builder, camera, seed)
  std::vector<json> a;
  ASSERT_NO_FATAL_FAILURE(same_results_either_way(dir, "trees", 4, &a));
  for (size_t i = 0; i < a.size(); ++i) {
    const json config = json::parse(a[i]["config_json"].get<std::string>());
    EXPECT_EQ(fs::path(config["inputs"]["bvh_file"].get<std::string>()).parent_path(), dir / "cache");
  }
}

// Two-level trees go through the tree cache too (built --instanced, replayed with
// --instanced --bvh), apart from the flat scene's tree, and change no result.
TEST(CampaignRun, InstancedJobsShareTheirTwoLevelTreeAndChangeNoResult) {
  const fs::path dir = test::fresh_folder("instanced-trees");
  EXPECT_EQ(run_with_and_without_tree_cache(
                dir, "[campaign]\nname = \"inst\"\n[sweep]\nscene = \"forest_instanced\"\nbuilder = \"sah\"\n"
                     "fidelity = \"functional\"\nresolution = \"12x12\"\ninstanced = [false, true]\n"
                     "preset = [\"mobile\", \"desktop\"]\n"),
            2u);  // the flat tree and the two-level one, each shared by two presets
  same_results_either_way(dir, "inst", 4);
}

// build.camera: view1's rays through the tree built for view2 use view2's tree (the
// cache shares it, and the build is not handed the workload's camera instead), with
// or without the cache.
TEST(CampaignRun, ATreeBuiltForAnotherCameraIsThatCamerasTree) {
  const fs::path dir = test::fresh_folder("unseen");
  EXPECT_EQ(run_with_and_without_tree_cache(
                dir, "[campaign]\nname = \"unseen\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"rdh\"\n"
                     "resolution = \"12x12\"\nbuild.rdh_resolution = 8\n"
                     "[[group]]\nname = \"own\"\ncamera = \"view2\"\n"
                     "[[group]]\nname = \"unseen\"\ncamera = \"view1\"\nbuild.camera = \"view2\"\n"
                     "[[group]]\nname = \"seen\"\ncamera = \"view1\"\n"),
            2u);  // view2's tree (twice) and view1's
  ResultsStore shared(dir / "shared" / "results.sqlite"), own(dir / "own" / "results.sqlite");
  const auto a = shared.rows("unseen"), b = own.rows("unseen");
  ASSERT_EQ(a.size(), 3u);
  ASSERT_EQ(b.size(), 3u);
  std::map<std::string, std::string> tree_of;  // group -> tree hash
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i]["stats_json"], b[i]["stats_json"]) << a[i]["label"];
    const json shared_in = json::parse(a[i]["config_json"].get<std::string>())["inputs"];
    const json own_in = json::parse(b[i]["config_json"].get<std::string>())["inputs"];
    EXPECT_EQ(shared_in["bvh_hash"], own_in["bvh_hash"]) << a[i]["label"];
    tree_of[a[i]["group_name"].get<std::string>()] = shared_in["bvh_hash"].get<std::string>();
  }
  EXPECT_EQ(tree_of.at("unseen"), tree_of.at("own"));
  EXPECT_NE(tree_of.at("unseen"), tree_of.at("seen"));
  // A camera the scene lacks is named with its key.
  test::write_text(dir / "bad.toml",
                   "[campaign]\nname = \"b\"\n[sweep]\nscene = \"cornell\"\nbuilder = \"rdh\"\n"
                   "build.camera = \"view9\"\n");
  try {
    load_campaign(dir / "bad.toml", "rev");
    ADD_FAILURE() << "view9 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("build.camera"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("view9"), std::string::npos) << e.what();
  }
}

// The same jobs under another campaign name (its own folder and database) are the
// same jobs: their keys are equal, and the results cache beside the tree cache
// records them from the first campaign's runs without running one.
TEST(CampaignRun, ARenamedCampaignRunsNoJob) {
  const Fixture f = make_fixture("renamed", 2);  // 2 builders x 2 presets x 2 seeds
  const std::string cache = " --results-cache " + shell_quote((f.dir / "results").string());
  ASSERT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + " -j 2" + f.work("a") + cache)), 0);
  EXPECT_EQ(read_lines(f.log).size(), 8u);
  const fs::path renamed = test::write_text(f.dir / "renamed.toml", test::small_campaign("demo-again", 2));
  ASSERT_EQ(shell(f.rtsim("campaign run " + renamed.string() + " -j 2 --json" + f.work("b") + cache)), 0);
  EXPECT_EQ(read_lines(f.log).size(), 8u) << "a job ran again";
  const json summary = json::parse(std::ifstream(f.dir / "out.txt"));
  EXPECT_EQ(summary["ran"], 0);
  EXPECT_EQ(summary["reused"], 8);
  EXPECT_EQ(summary["ok"], 8);
  // The renamed campaign's rows are its own (name, labels), with the first run's numbers.
  ResultsStore first(f.dir / "a" / "results.sqlite"), second(f.dir / "b" / "results.sqlite");
  const std::vector<json> a = first.rows("demo"), b = second.rows("demo-again");
  ASSERT_EQ(a.size(), 8u);
  ASSERT_EQ(b.size(), 8u);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(b[i]["job_key"], a[i]["job_key"]);
    EXPECT_EQ(b[i]["campaign"], "demo-again");
    EXPECT_EQ(b[i]["stats_json"], a[i]["stats_json"]);
    EXPECT_EQ(b[i]["status"], "ok");
  }
  // Without the cache the renamed campaign runs its jobs, as before.
  ASSERT_EQ(shell(f.rtsim("campaign run " + renamed.string() + " --no-results-cache" + f.work("c"))), 0);
  EXPECT_EQ(read_lines(f.log).size(), 16u);
}

TEST(CampaignRun, BadCampaignFileExitsWithTwoAndNamesTheKey) {
  const Fixture f = make_fixture("bad", 1);
  test::write_text(f.campaign, "[sweep]\nscene = \"interior\"\nbuilder = \"sah\"\nseeds = 3\n");
  EXPECT_EQ(shell(f.rtsim("campaign run " + f.campaign.string() + f.work("w"))), 2);
  const auto err = read_lines(f.dir / "err.txt");
  ASSERT_FALSE(err.empty());
  EXPECT_NE(err[0].find("sweep.seeds"), std::string::npos) << err[0];
}

}  // namespace
}  // namespace rtsim
