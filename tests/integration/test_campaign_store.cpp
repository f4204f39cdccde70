// The SQLite results store: headline columns, idempotent records, concurrent writers.
#include "integration/test_campaign_fake.h"

#include <rtsim/reports/results_store.h>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

namespace rtsim {
namespace {

using nlohmann::json;

json leaf(double v, const char* unit) { return {{"value", v}, {"unit", unit}, {"description", "d"}}; }

RunRecord make_run(const std::string& key, double cycles) {
  RunRecord r;
  r.campaign = "c";
  r.job_key = key;
  r.label = "scene/" + key;
  r.group = "default";
  r.config_hash = "cfg" + key;
  r.revision = "rev";
  r.status = "ok";
  r.host_seconds = 0.5;
  r.finished_at = "2024-01-01T00:00:00Z";
  r.job = {{"scene", "interior"}, {"builder", "sah"}, {"seed", "3"}, {"set", json::object()}};
  r.config = {{"seed", 3}};
  r.stats = {{"rays", {{"total", leaf(100, "rays")}}},
             {"time", {{"cycles", leaf(cycles, "cycles")}}},
             {"ops", {{"trv", leaf(700, "ops")}, {"ist", leaf(300, "ops")}}},
             {"fetches", {{"node", leaf(650, "fetches")}}},
             {"l2", {{"accesses", leaf(200, "a")}, {"hits", leaf(50, "h")}}},
             {"dram", {{"bytes", leaf(12800, "bytes")},
                       {"bytes_by_type", {{"ao", {{"node", leaf(6400, "bytes")}}}}}}}};
  r.host = {{"rays_per_host_second", leaf(5e5, "rays/s")}};
  return r;
}

TEST(ResultsStore, HeadlineColumnsComeFromStats) {
  const auto dir = test::fresh_folder("headline");
  ResultsStore store(dir / "r.sqlite");
  EXPECT_EQ(store.record(make_run("k1", 5000)), ResultsStore::Outcome::Inserted);
  const auto rows = store.rows("c");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_DOUBLE_EQ(rows[0]["ops_per_ray"].get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(rows[0]["trv_ops_per_ray"].get<double>(), 7.0);
  EXPECT_DOUBLE_EQ(rows[0]["node_fetches_per_ray"].get<double>(), 6.5);
  EXPECT_DOUBLE_EQ(rows[0]["dram_bytes_per_ray"].get<double>(), 128.0);
  EXPECT_DOUBLE_EQ(rows[0]["l2_hit_rate"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(rows[0]["cycles"].get<double>(), 5000.0);
  EXPECT_TRUE(rows[0]["l1_node_hit_rate"].is_null());  // not reported -> NULL, not 0
  EXPECT_DOUBLE_EQ(rows[0]["rays_per_host_second"].get<double>(), 5e5);
  EXPECT_EQ(rows[0]["seed"].get<int64_t>(), 3);
  EXPECT_EQ(json::parse(rows[0]["stats_json"].get<std::string>()), make_run("k1", 5000).stats);
  const auto split = dram_bytes_per_ray_split(make_run("k1", 5000).stats);
  ASSERT_EQ(split.size(), 1u);
  EXPECT_DOUBLE_EQ(split.at({"ao", "node"}), 64.0);
}

TEST(ResultsStore, RecordingIsIdempotentAndOkIsNotOverwrittenByAFailure) {
  const auto dir = test::fresh_folder("idem");
  ResultsStore store(dir / "r.sqlite");
  const RunRecord ok = make_run("k", 1000);
  EXPECT_EQ(store.record(ok), ResultsStore::Outcome::Inserted);
  EXPECT_EQ(store.record(ok), ResultsStore::Outcome::Unchanged);
  RunRecord failed = ok;
  failed.status = "failed";
  failed.error = "boom";
  EXPECT_EQ(store.record(failed), ResultsStore::Outcome::KeptOk);
  EXPECT_EQ(store.summaries("c").at("k").status, "ok");
  RunRecord rerun = make_run("k", 2000);
  EXPECT_EQ(store.record(rerun), ResultsStore::Outcome::Replaced);
  EXPECT_EQ(store.rows("c").size(), 1u);
  EXPECT_DOUBLE_EQ(store.rows("c")[0]["cycles"].get<double>(), 2000.0);
  // A record survives a round trip through its result-file JSON.
  const RunRecord back = RunRecord::from_json(json::parse(ok.to_json().dump()), "f");
  EXPECT_EQ(back.to_json(), ok.to_json());
  EXPECT_THROW(RunRecord::from_json(json{{"campaign", 1}}, "f"), std::exception);
}

// Several processes write into one database at once: every run arrives exactly once
// and the database stays healthy (WAL + busy timeout, one transaction per run).
TEST(ResultsStore, ConcurrentWritersLoseNothing) {
  const auto dir = test::fresh_folder("concurrent");
  const auto db = dir / "r.sqlite";
  constexpr int kWriters = 4, kRunsEach = 60;
  std::vector<pid_t> children;
  for (int w = 0; w < kWriters; ++w) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      int code = 0;
      try {
        ResultsStore store(db);
        for (int i = 0; i < kRunsEach; ++i) {
          store.record(make_run("w" + std::to_string(w) + "-" + std::to_string(i), i));
          // Every writer also records the same shared runs: must stay one row each.
          store.record(make_run("shared-" + std::to_string(i % 10), 42));
        }
      } catch (const std::exception& e) {
        std::fprintf(stderr, "writer %d: %s\n", w, e.what());
        code = 1;
      }
      _exit(code);
    }
    children.push_back(pid);
  }
  for (pid_t pid : children) {
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  ResultsStore store(db);
  EXPECT_EQ(store.integrity_check(), "ok");
  const auto rows = store.rows("c");
  EXPECT_EQ(rows.size(), size_t(kWriters * kRunsEach + 10));
  for (int w = 0; w < kWriters; ++w)
    for (int i = 0; i < kRunsEach; ++i)
      EXPECT_EQ(store.summaries("c").count("w" + std::to_string(w) + "-" + std::to_string(i)), 1u);
}

}  // namespace
}  // namespace rtsim
