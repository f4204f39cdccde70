// kill -9 of `rtsim campaign run` at arbitrary moments: rerunning runs only the missing
// jobs, no finished run is lost or stored twice, and the database passes
// PRAGMA integrity_check. Uses the fake simulator (slow jobs on demand).
#include "integration/test_campaign_fake.h"

#include <rtsim/reports/campaign_runner.h>
#include <rtsim/reports/results_store.h>

#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <thread>

namespace rtsim {
namespace {

namespace fs = std::filesystem;

// Starts `rtsim campaign run` in the background and returns its pid.
// `hold_until` non-empty: every job waits for that file before it finishes.
pid_t start_runner(const fs::path& campaign, const fs::path& work, const fs::path& fake,
                   const fs::path& log, const std::string& sleep_seconds, const fs::path& hold_until = {}) {
  const pid_t pid = fork();
  if (pid == 0) {
    setenv("FAKE_LOG", log.c_str(), 1);
    setenv("FAKE_SLEEP", sleep_seconds.c_str(), 1);
    if (!hold_until.empty()) setenv("FAKE_HOLD_UNTIL", hold_until.c_str(), 1);
    const int null_fd = open("/dev/null", O_WRONLY);
    dup2(null_fd, 1);
    dup2(null_fd, 2);
    execl(RTSIM_BINARY, RTSIM_BINARY, "campaign", "run", campaign.c_str(), "-j", "3", "--out-dir",
          work.c_str(), "--rtsim", fake.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

// Keys of the jobs started so far, from the fake's log of --out folders (one per start).
std::multiset<std::string> started_keys(const fs::path& log) {
  std::multiset<std::string> keys;
  for (const std::string& line : test::read_lines(log)) keys.insert(fs::path(line).filename());
  return keys;
}

std::set<std::string> finished_keys(const fs::path& work) {
  std::set<std::string> keys;
  {
    ResultsStore store(work / "results.sqlite");
    for (const auto& [key, summary] : store.summaries("demo")) keys.insert(key);
  }
  if (fs::is_directory(work / "results"))
    for (const auto& e : fs::directory_iterator(work / "results"))
      if (e.path().extension() == ".json") keys.insert(e.path().stem());
  return keys;
}

TEST(CampaignKill, ResumeAfterKill9RunsOnlyMissingJobs) {
  const fs::path dir = test::fresh_folder("kill");
  const fs::path fake = test::write_fake_rtsim(dir);
  const fs::path campaign = test::write_text(dir / "c.toml", test::small_campaign("demo", 8));
  const fs::path work = dir / "w", log = dir / "fake.log";
  constexpr size_t kJobs = 32;  // 2 builders x 2 presets x 8 seeds

  // Kill at several moments: early, mid-way, and again on the resumed run.
  std::set<std::string> finished_before;
  for (int delay_ms : {350, 500, 420}) {
    const size_t started_before = started_keys(log).size();
    const pid_t runner = start_runner(campaign, work, fake, log, "0.2");
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    ASSERT_EQ(kill(runner, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(waitpid(runner, &status, 0), runner);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the runner finished before it could be killed";
    // Jobs started by this round must not include any job finished before it.
    const auto all_started = started_keys(log);
    std::vector<std::string> lines = test::read_lines(log);
    for (size_t i = started_before; i < lines.size(); ++i)
      EXPECT_EQ(finished_before.count(fs::path(lines[i]).filename()), 0u)
          << "a finished job was started again";
    finished_before = finished_keys(work);
    EXPECT_LT(finished_before.size(), kJobs);
    ResultsStore store(work / "results.sqlite");
    EXPECT_EQ(store.integrity_check(), "ok");
  }
  // Children died with the runner (PR_SET_PDEATHSIG): nothing appears after the kill.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(finished_keys(work), finished_before);

  // The final run completes the campaign, running exactly the missing jobs.
  const size_t started_before = test::read_lines(log).size();
  const pid_t runner = start_runner(campaign, work, fake, log, "0");
  int status = 0;
  ASSERT_EQ(waitpid(runner, &status, 0), runner);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  const auto lines = test::read_lines(log);
  std::set<std::string> final_run;
  for (size_t i = started_before; i < lines.size(); ++i)
    final_run.insert(fs::path(lines[i]).filename());
  EXPECT_EQ(lines.size() - started_before, final_run.size());  // none twice
  EXPECT_EQ(final_run.size(), kJobs - finished_before.size());
  for (const std::string& k : final_run) EXPECT_EQ(finished_before.count(k), 0u);

  ResultsStore store(work / "results.sqlite");
  EXPECT_EQ(store.integrity_check(), "ok");
  const auto rows = store.rows("demo");
  ASSERT_EQ(rows.size(), kJobs);
  std::set<std::string> keys;
  for (const auto& r : rows) {
    EXPECT_EQ(r["status"], "ok");
    keys.insert(r["job_key"].get<std::string>());
  }
  EXPECT_EQ(keys.size(), kJobs);
}

// A runner killed after writing a job's result file but before its transaction: the
// next run stores that result without running the job again.
TEST(CampaignKill, ResultFileWithoutDatabaseRowIsCollectedNotRerun) {
  const fs::path dir = test::fresh_folder("orphan");
  const fs::path fake = test::write_fake_rtsim(dir);
  const fs::path campaign = test::write_text(dir / "c.toml", test::small_campaign("demo", 1));
  const fs::path work = dir / "w", log = dir / "fake.log";
  const Campaign c = load_campaign(campaign, "fakerev1");
  const CampaignPaths paths = campaign_paths(c, work, "");
  setenv("FAKE_LOG", log.c_str(), 1);
  const RunRecord r = run_one_job(c, c.jobs[1], paths, fake, 0, false);
  ASSERT_EQ(r.status, "ok");
  ASSERT_EQ(test::read_lines(log).size(), 1u);

  RunOptions o;
  o.binary = fake;
  o.parallel = 2;
  const RunSummary s = run_campaign(c, paths, o);
  unsetenv("FAKE_LOG");
  EXPECT_EQ(s.collected, 1u);
  EXPECT_EQ(s.ran, c.jobs.size() - 1);
  const auto lines = test::read_lines(log);
  EXPECT_EQ(lines.size(), c.jobs.size());
  EXPECT_EQ(std::count(lines.begin(), lines.end(), lines[0]), 1);
  ResultsStore store(paths.database);
  EXPECT_EQ(store.rows("demo").size(), c.jobs.size());
}

// Two runners on one campaign at once would do the work twice: the second is refused.
// The first runner's jobs are held (FAKE_HOLD_UNTIL) and the second starts only once
// a job of the first is running, so the first holds run.lock then, whatever the
// load (a 200 ms sleep stood for that and failed at a load average of 8).
TEST(CampaignKill, SecondConcurrentRunnerIsRefused) {
  const fs::path dir = test::fresh_folder("lock");
  const fs::path fake = test::write_fake_rtsim(dir);
  const fs::path campaign = test::write_text(dir / "c.toml", test::small_campaign("demo", 1));
  const fs::path work = dir / "w", log = dir / "fake.log", go = dir / "go";
  const pid_t first = start_runner(campaign, work, fake, log, "0", go);
  // However the test ends, the held jobs are let go (no runner left waiting).
  struct Release {
    fs::path go;
    ~Release() { std::ofstream{go}; }
  } release{go};
  // A started job means the lock is held: the runner takes it before any job.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  int status = 0;
  while (test::read_lines(log).empty()) {  // polled: the condition, not a guess at its time
    ASSERT_NE(waitpid(first, &status, WNOHANG), first) << "the first runner ended before starting a job";
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the first runner started no job in 120 s";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const Campaign c = load_campaign(campaign, "fakerev1");
  RunOptions o;
  o.binary = fake;
  std::string refusal;
  try {
    run_campaign(c, campaign_paths(c, work, ""), o);
  } catch (const std::exception& e) {
    refusal = e.what();
  }
  EXPECT_NE(refusal.find("run.lock is held"), std::string::npos) << "refused for another reason: " << refusal;
  test::write_text(go, "");
  ASSERT_EQ(waitpid(first, &status, 0), first);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  // The first runner did all the work, each job once.
  EXPECT_EQ(test::read_lines(log).size(), c.jobs.size());
}

}  // namespace
}  // namespace rtsim
