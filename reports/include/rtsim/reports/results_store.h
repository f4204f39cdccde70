#pragma once
// The results store of campaigns: one SQLite database, one row per (campaign, job key)
// holding the run's status, error text, host seconds, the headline statistics as
// columns and the full config.json / stats.json. Each run is written in one
// transaction; WAL and a busy timeout make concurrent writers (several runners,
// `campaign collect` beside a run) safe, and a kill -9 loses at most the run being
// written, never the database.
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

struct sqlite3;

namespace rtsim {

// One finished (or failed) job, as written to a per-job result file and to the store.
struct RunRecord {
  std::string campaign, job_key, label, group, config_hash, revision;
  std::string status;  // "ok" | "failed"
  std::string error;   // why it failed (tail of the job's log), empty when ok
  double host_seconds = 0;
  std::string finished_at;  // UTC, ISO 8601
  nlohmann::json job;       // the resolved job description (CampaignJob::resolved)
  nlohmann::json config;    // config.json of the run (null if it never appeared)
  nlohmann::json stats;     // stats.json of the run (null if it never appeared)
  nlohmann::json host;      // host.json: host seconds, rays per host second, peak memory

  nlohmann::json to_json() const;
  // Throws InputError naming `where` if fields are missing or of the wrong type.
  static RunRecord from_json(const nlohmann::json& j, const std::string& where);
};

// The numbers a campaign compares, pulled out of a stats.json. NaN = not reported.
struct HeadlineStats {
  double rays = NAN, cycles = NAN, ops_per_ray = NAN, trv_ops_per_ray = NAN,
         ist_ops_per_ray = NAN, node_fetches_per_ray = NAN, triangle_fetches_per_ray = NAN,
         dram_bytes_per_ray = NAN, l1_node_hit_rate = NAN, l1_triangle_hit_rate = NAN,
         l2_hit_rate = NAN, rays_per_host_second = NAN;
};
HeadlineStats headline_stats(const nlohmann::json& stats, const nlohmann::json& host);

// Every leaf {value, unit, description} of a hierarchical stats.json by dotted path.
std::map<std::string, double> flatten_stats(const nlohmann::json& stats);

// DRAM bytes per ray split by (ray type, data kind), e.g. {"primary", "node"} -> 812.5,
// from the stats' byte attribution; empty if the run did not report one.
std::map<std::pair<std::string, std::string>, double> dram_bytes_per_ray_split(
    const nlohmann::json& stats);

class ResultsStore {
 public:
  // ReadWrite: opens (creating if needed) the database and its schema; a database
  // that holds another program's tables is refused (InputError), never written to.
  // ReadOnly (status, export, report): opens an existing rtsim database without
  // writing anything; a missing file reads as an empty store and is not created;
  // a file that is not an SQLite database, or not rtsim's, is an InputError.
  // std::runtime_error naming the file for anything else.
  enum class Access { ReadWrite, ReadOnly };
  explicit ResultsStore(const std::filesystem::path& file, Access access = Access::ReadWrite);
  ~ResultsStore();
  ResultsStore(const ResultsStore&) = delete;
  ResultsStore& operator=(const ResultsStore&) = delete;

  enum class Outcome { Inserted, Replaced, Unchanged, KeptOk };
  // One transaction. A row that is "ok" is only replaced by another "ok" run (a forced
  // rerun); recording the same run twice leaves the row unchanged (idempotent collect).
  Outcome record(const RunRecord& run);

  struct Summary {
    std::string status, error, label, revision, finished_at;
    nlohmann::json job;  // the resolved job description it ran with
    double host_seconds = 0;
  };
  std::map<std::string, Summary> summaries(const std::string& campaign) const;  // by job key
  // Every column of every row of a campaign ("" = all campaigns), ordered by job key.
  std::vector<nlohmann::json> rows(const std::string& campaign) const;
  std::vector<std::string> campaigns() const;
  std::string integrity_check() const;  // "ok" when healthy
  bool exists() const { return db_ != nullptr; }  // false: a read-only store of a missing file
  const std::filesystem::path& file() const { return file_; }

  // Headline columns in export order (name, unit).
  static const std::vector<std::pair<std::string, std::string>>& headline_columns();

 private:
  std::filesystem::path file_;
  sqlite3* db_ = nullptr;
};

}  // namespace rtsim
