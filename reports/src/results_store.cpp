// SQLite results store of campaigns (sqlite3 C API).
#include <rtsim/reports/results_store.h>

#include <rtsim/reports/campaign.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/model/sim/stat_names.h>

#include <sqlite3.h>

#include <chrono>
#include <stdexcept>
#include <thread>

namespace rtsim {

namespace fs = std::filesystem;
using nlohmann::json;

// ---------------------------------------------------------------- run records

json RunRecord::to_json() const {
  return {{"campaign", campaign}, {"job_key", job_key},   {"label", label},
          {"group", group},       {"config_hash", config_hash}, {"revision", revision},
          {"status", status},     {"error", error},       {"host_seconds", host_seconds},
          {"finished_at", finished_at}, {"job", job},     {"config", config},
          {"stats", stats},       {"host", host}};
}

RunRecord RunRecord::from_json(const json& j, const std::string& where) {
  if (!j.is_object()) throw InputError(where, "a run record must be a JSON object");
  auto text = [&](const char* k) {
    if (!j.contains(k) || !j[k].is_string())
      throw InputError(where, std::string("field '") + k + "' must be a string");
    return j[k].get<std::string>();
  };
  RunRecord r;
  r.campaign = text("campaign");
  r.job_key = text("job_key");
  r.label = text("label");
  r.group = text("group");
  r.config_hash = text("config_hash");
  r.revision = text("revision");
  r.status = text("status");
  r.error = text("error");
  r.finished_at = text("finished_at");
  if (r.status != "ok" && r.status != "failed")
    throw InputError(where, "field 'status' must be \"ok\" or \"failed\"");
  if (!j.contains("host_seconds") || !j["host_seconds"].is_number())
    throw InputError(where, "field 'host_seconds' must be a number");
  r.host_seconds = j["host_seconds"].get<double>();
  r.job = j.value("job", json());
  r.config = j.value("config", json());
  r.stats = j.value("stats", json());
  r.host = j.value("host", json());
  if (r.status == "ok" && !r.stats.is_object())
    throw InputError(where, "an ok run needs a 'stats' object");
  return r;
}

// ---------------------------------------------------------------- stats

namespace {

void flatten_into(const json& node, const std::string& prefix, std::map<std::string, double>& out) {
  if (!node.is_object()) return;
  // A leaf is {value, unit, ...}; anything else is a level of the hierarchy.
  if (node.contains("value") && node["value"].is_number() && node.contains("unit")) {
    out[prefix] = node["value"].get<double>();
    return;
  }
  for (auto it = node.begin(); it != node.end(); ++it)
    flatten_into(it.value(), prefix.empty() ? it.key() : prefix + "." + it.key(), out);
}

// The first of several names a statistic may carry (the model's naming may grow).
double first_of(const std::map<std::string, double>& s, std::initializer_list<const char*> names) {
  for (const char* n : names) {
    auto it = s.find(n);
    if (it != s.end()) return it->second;
  }
  return NAN;
}

double ratio(double a, double b) { return (std::isfinite(a) && b > 0) ? a / b : NAN; }

// A cache level's hit rate: over all instances ("l1_node.all.*") or the one cache.
double hit_rate(const std::map<std::string, double>& s, const std::string& cache) {
  for (const std::string& prefix : {cache + ".all.", cache + "."}) {
    const double direct = first_of(s, {(prefix + "hit_rate").c_str()});
    if (std::isfinite(direct)) return direct;
    const double derived =
        ratio(first_of(s, {(prefix + "hits").c_str()}), first_of(s, {(prefix + "accesses").c_str()}));
    if (std::isfinite(derived)) return derived;
  }
  return NAN;
}

}  // namespace

std::map<std::string, double> flatten_stats(const json& stats) {
  std::map<std::string, double> out;
  flatten_into(stats, "", out);
  return out;
}

HeadlineStats headline_stats(const json& stats, const json& host) {
  const auto s = flatten_stats(stats);
  HeadlineStats h;
  h.rays = first_of(s, {"rays.total", "raygen.rays", "rays"});
  h.cycles = first_of(s, {"time.cycles", "sim.cycles", "cycles"});
  const double trv_ops = first_of(s, {"ops.trv", "trv.ops"});
  const double ist_ops = first_of(s, {"ops.ist", "ist.ops"});
  h.trv_ops_per_ray = ratio(trv_ops, h.rays);
  h.ist_ops_per_ray = ratio(ist_ops, h.rays);
  h.ops_per_ray = ratio(trv_ops + ist_ops, h.rays);
  h.node_fetches_per_ray = ratio(first_of(s, {"fetches.node", "trv.node_fetches"}), h.rays);
  h.triangle_fetches_per_ray =
      ratio(first_of(s, {"fetches.triangle", "ist.triangle_fetches"}), h.rays);
  h.dram_bytes_per_ray = ratio(first_of(s, {"dram.bytes", "dram.read_bytes"}), h.rays);
  h.l1_node_hit_rate = hit_rate(s, "l1_node");
  h.l1_triangle_hit_rate = hit_rate(s, "l1_triangle");
  h.l2_hit_rate = hit_rate(s, "l2");
  // Host speed lives in host.json (kept out of stats.json so that stays byte-identical).
  const auto host_values = flatten_stats(host);
  h.rays_per_host_second = first_of(host_values, {"rays_per_host_second"});
  if (!std::isfinite(h.rays_per_host_second))
    h.rays_per_host_second = first_of(s, {"host.rays_per_host_second"});
  return h;
}

std::map<std::pair<std::string, std::string>, double> dram_bytes_per_ray_split(const json& stats) {
  const auto s = flatten_stats(stats);
  const double rays = headline_stats(stats, json()).rays;
  std::map<std::pair<std::string, std::string>, double> out;
  // dram.bytes_by_type.<ray type>.<kind>: bytes attributed to a ray type and a data kind.
  const std::string prefix = std::string(sim::stat::kDramBytesByType) + ".";
  for (auto it = s.lower_bound(prefix); it != s.end() && it->first.rfind(prefix, 0) == 0; ++it) {
    const std::string rest = it->first.substr(prefix.size());
    const size_t dot = rest.find('.');
    if (dot == std::string::npos) continue;
    out[{rest.substr(0, dot), rest.substr(dot + 1)}] = ratio(it->second, rays);
  }
  return out;
}

// ---------------------------------------------------------------- store

namespace {

class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK)
      throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(db) + " in: " + sql);
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement& bind(int i, const std::string& v) {
    sqlite3_bind_text(stmt_, i, v.data(), int(v.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Statement& bind(int i, double v) {
    if (std::isfinite(v))
      sqlite3_bind_double(stmt_, i, v);
    else
      sqlite3_bind_null(stmt_, i);
    return *this;
  }
  Statement& bind_int(int i, int64_t v) {
    sqlite3_bind_int64(stmt_, i, v);
    return *this;
  }
  bool step() {  // true: a row is available
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(db_));
  }
  std::string text(int col) const {
    const unsigned char* t = sqlite3_column_text(stmt_, col);
    return t ? reinterpret_cast<const char*>(t) : "";
  }
  double real(int col) const { return sqlite3_column_double(stmt_, col); }
  sqlite3_stmt* get() const { return stmt_; }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

void exec(sqlite3* db, const char* sql) {
  char* message = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    std::string m = message ? message : sqlite3_errmsg(db);
    sqlite3_free(message);
    throw std::runtime_error("sqlite: " + m + " in: " + sql);
  }
}

// Switching a new database to WAL takes an exclusive lock, and SQLite answers
// SQLITE_BUSY at once, without the busy handler, when waiting could deadlock
// (two new writers racing on the first open). So this one statement retries,
// for as long as the busy timeout would have waited.
void enable_wal(sqlite3* db, int timeout_ms) {
  for (int waited_ms = 0;; waited_ms += 10) {
    const int rc = sqlite3_exec(db, "PRAGMA journal_mode=WAL", nullptr, nullptr, nullptr);
    if (rc == SQLITE_OK) return;
    if ((rc != SQLITE_BUSY && rc != SQLITE_LOCKED) || waited_ms >= timeout_ms)
      throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(db) +
                               " in: PRAGMA journal_mode=WAL");
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

// Bumped when columns change; an older database is refused with a clear message.
constexpr int kSchemaVersion = 1;

const char* const kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs(
  campaign TEXT NOT NULL,
  job_key TEXT NOT NULL,
  label TEXT NOT NULL,
  group_name TEXT NOT NULL,
  config_hash TEXT NOT NULL,
  git_revision TEXT NOT NULL,
  status TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
  error TEXT NOT NULL,
  host_seconds REAL,
  finished_at TEXT NOT NULL,
  scene TEXT, builder TEXT, camera TEXT, preset TEXT, fidelity TEXT, seed INTEGER,
  overrides TEXT,
  rays REAL, cycles REAL, ops_per_ray REAL, trv_ops_per_ray REAL, ist_ops_per_ray REAL,
  node_fetches_per_ray REAL, triangle_fetches_per_ray REAL, dram_bytes_per_ray REAL,
  l1_node_hit_rate REAL, l1_triangle_hit_rate REAL, l2_hit_rate REAL,
  rays_per_host_second REAL,
  job_json TEXT NOT NULL, config_json TEXT NOT NULL, stats_json TEXT NOT NULL,
  host_json TEXT NOT NULL,
  record_hash TEXT NOT NULL,
  PRIMARY KEY (campaign, job_key));
)sql";

}  // namespace

const std::vector<std::pair<std::string, std::string>>& ResultsStore::headline_columns() {
  static const std::vector<std::pair<std::string, std::string>> columns = {
      {"rays", "rays"},
      {"cycles", "cycles"},
      {"ops_per_ray", "ops/ray"},
      {"trv_ops_per_ray", "ops/ray"},
      {"ist_ops_per_ray", "ops/ray"},
      {"node_fetches_per_ray", "fetches/ray"},
      {"triangle_fetches_per_ray", "fetches/ray"},
      {"dram_bytes_per_ray", "bytes/ray"},
      {"l1_node_hit_rate", "fraction"},
      {"l1_triangle_hit_rate", "fraction"},
      {"l2_hit_rate", "fraction"},
      {"rays_per_host_second", "rays/s"}};
  return columns;
}

namespace {

// What a database holds, asked before rtsim reads or writes it: its tables, and
// whether it is rtsim's (a meta table with a schema_version). InputError for a
// file that is not an SQLite database at all.
struct DatabaseKind {
  bool empty = true;  // no tables
  bool rtsim = false;
  std::string schema_version;
};

DatabaseKind inspect(sqlite3* db, const fs::path& file) {
  DatabaseKind kind;
  sqlite3_stmt* q = nullptr;
  if (sqlite3_prepare_v2(db, "SELECT name FROM sqlite_master WHERE type='table'", -1, &q, nullptr) != SQLITE_OK) {
    const int code = sqlite3_errcode(db);
    const std::string m = sqlite3_errmsg(db);
    if (code == SQLITE_NOTADB || code == SQLITE_CORRUPT)
      throw InputError(file.string(), "is not an SQLite database (" + m + ")");
    throw std::runtime_error(file.string() + ": " + m);
  }
  bool has_meta = false;
  int rc;
  while ((rc = sqlite3_step(q)) == SQLITE_ROW) {
    kind.empty = false;
    const unsigned char* name = sqlite3_column_text(q, 0);
    if (name && std::string(reinterpret_cast<const char*>(name)) == "meta") has_meta = true;
  }
  sqlite3_finalize(q);
  if (rc != SQLITE_DONE) {
    const int code = sqlite3_errcode(db);
    const std::string m = sqlite3_errmsg(db);
    if (code == SQLITE_NOTADB || code == SQLITE_CORRUPT)
      throw InputError(file.string(), "is not an SQLite database (" + m + ")");
    throw std::runtime_error(file.string() + ": " + m);
  }
  if (has_meta &&
      sqlite3_prepare_v2(db, "SELECT value FROM meta WHERE key='schema_version'", -1, &q, nullptr) == SQLITE_OK) {
    if (sqlite3_step(q) == SQLITE_ROW) {
      kind.rtsim = true;
      const unsigned char* v = sqlite3_column_text(q, 0);
      kind.schema_version = v ? reinterpret_cast<const char*>(v) : "";
    }
    sqlite3_finalize(q);
  }
  return kind;
}

}  // namespace

ResultsStore::ResultsStore(const fs::path& file, Access access) : file_(file) {
  if (access == Access::ReadOnly) {
    if (!path_exists(file)) return;  // nothing recorded yet; and nothing is created
    if (!is_file(file)) throw InputError(file.string(), "is not a file");
    if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      const std::string m = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      db_ = nullptr;
      throw InputError(file.string(), "cannot open the results database: " + m);
    }
    sqlite3_busy_timeout(db_, 60000);
    try {
      const DatabaseKind kind = inspect(db_, file);
      if (!kind.rtsim)
        throw InputError(file.string(), kind.empty ? "is an empty database, not an rtsim results database"
                                                   : "is another program's database, not an rtsim "
                                                     "results database (no meta.schema_version)");
      if (kind.schema_version != std::to_string(kSchemaVersion))
        throw InputError(file.string(), "schema version " + kind.schema_version + ", this rtsim reads " +
                                            std::to_string(kSchemaVersion));
    } catch (...) {
      sqlite3_close(db_);
      db_ = nullptr;
      throw;
    }
    return;
  }
  if (path_exists(file) && !is_file(file)) throw InputError(file.string(), "is not a file");
  if (file.has_parent_path()) fs::create_directories(file.parent_path());
  if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) !=
      SQLITE_OK) {
    const std::string m = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw std::runtime_error(file.string() + ": cannot open the results database: " + m);
  }
  try {
    // Writers queue for up to a minute instead of failing with "database is locked".
    constexpr int kBusyTimeoutMs = 60000;
    sqlite3_busy_timeout(db_, kBusyTimeoutMs);
    // Someone else's database is never written into.
    const DatabaseKind kind = inspect(db_, file);
    if (!kind.empty && !kind.rtsim)
      throw InputError(file.string(), "holds another program's tables; rtsim writes only into a new "
                                      "database or one of its own");
    enable_wal(db_, kBusyTimeoutMs);
    // WAL + NORMAL: a killed process never loses a committed run (only power loss could).
    exec(db_, "PRAGMA synchronous=NORMAL");
    exec(db_, "BEGIN IMMEDIATE");
    exec(db_, kSchema);
    Statement get(db_, "SELECT value FROM meta WHERE key='schema_version'");
    if (get.step()) {
      if (get.text(0) != std::to_string(kSchemaVersion))
        throw std::runtime_error("schema version " + get.text(0) + ", this rtsim writes " +
                                 std::to_string(kSchemaVersion));
    } else {
      Statement put(db_, "INSERT INTO meta(key, value) VALUES('schema_version', ?1)");
      put.bind(1, std::to_string(kSchemaVersion)).step();
    }
    exec(db_, "COMMIT");
  } catch (const InputError&) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  } catch (const std::exception& e) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(file.string() + ": " + e.what());
  }
}

ResultsStore::~ResultsStore() { sqlite3_close(db_); }

ResultsStore::Outcome ResultsStore::record(const RunRecord& run) {
  if (!db_) throw std::logic_error(file_.string() + ": a read-only store records nothing");
  const std::string record_text = run.to_json().dump();
  const std::string record_hash = content_hash_hex(record_text);
  const HeadlineStats h = run.stats.is_object() ? headline_stats(run.stats, run.host) : HeadlineStats{};
  exec(db_, "BEGIN IMMEDIATE");
  try {
    Outcome outcome = Outcome::Inserted;
    {
      Statement q(db_, "SELECT status, record_hash FROM runs WHERE campaign=?1 AND job_key=?2");
      q.bind(1, run.campaign).bind(2, run.job_key);
      if (q.step()) {
        if (q.text(1) == record_hash) outcome = Outcome::Unchanged;
        else if (q.text(0) == "ok" && run.status != "ok") outcome = Outcome::KeptOk;
        else outcome = Outcome::Replaced;
      }
    }
    if (outcome == Outcome::Inserted || outcome == Outcome::Replaced) {
      Statement ins(db_, R"sql(
INSERT OR REPLACE INTO runs(campaign, job_key, label, group_name, config_hash, git_revision,
  status, error, host_seconds, finished_at, scene, builder, camera, preset, fidelity, seed,
  overrides, rays, cycles, ops_per_ray, trv_ops_per_ray, ist_ops_per_ray, node_fetches_per_ray,
  triangle_fetches_per_ray, dram_bytes_per_ray, l1_node_hit_rate, l1_triangle_hit_rate,
  l2_hit_rate, rays_per_host_second, job_json, config_json, stats_json, record_hash, host_json)
VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19,
  ?20, ?21, ?22, ?23, ?24, ?25, ?26, ?27, ?28, ?29, ?30, ?31, ?32, ?33, ?34))sql");
      auto job_text = [&](const char* k) {
        return run.job.is_object() && run.job.contains(k) && run.job[k].is_string()
                   ? run.job[k].get<std::string>()
                   : std::string();
      };
      ins.bind(1, run.campaign).bind(2, run.job_key).bind(3, run.label).bind(4, run.group);
      ins.bind(5, run.config_hash).bind(6, run.revision).bind(7, run.status).bind(8, run.error);
      ins.bind(9, run.host_seconds).bind(10, run.finished_at);
      ins.bind(11, job_text("scene")).bind(12, job_text("builder")).bind(13, job_text("camera"));
      ins.bind(14, job_text("preset")).bind(15, job_text("fidelity"));
      const std::string seed = job_text("seed");
      if (seed.empty()) sqlite3_bind_null(ins.get(), 16);
      else ins.bind_int(16, std::stoll(seed));
      ins.bind(17, run.job.is_object() && run.job.contains("set") ? run.job["set"].dump()
                                                                   : std::string("{}"));
      const double values[] = {h.rays,
                               h.cycles,
                               h.ops_per_ray,
                               h.trv_ops_per_ray,
                               h.ist_ops_per_ray,
                               h.node_fetches_per_ray,
                               h.triangle_fetches_per_ray,
                               h.dram_bytes_per_ray,
                               h.l1_node_hit_rate,
                               h.l1_triangle_hit_rate,
                               h.l2_hit_rate,
                               h.rays_per_host_second};
      for (int i = 0; i < 12; ++i) ins.bind(18 + i, values[i]);
      ins.bind(30, run.job.dump()).bind(31, run.config.dump()).bind(32, run.stats.dump());
      ins.bind(33, record_hash).bind(34, run.host.dump());
      ins.step();
    }
    exec(db_, "COMMIT");
    return outcome;
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

std::map<std::string, ResultsStore::Summary> ResultsStore::summaries(
    const std::string& campaign) const {
  std::map<std::string, Summary> out;
  if (!db_) return out;
  Statement q(db_,
              "SELECT job_key, status, error, label, git_revision, host_seconds, finished_at, job_json "
              "FROM runs WHERE campaign=?1");
  q.bind(1, campaign);
  while (q.step()) {
    Summary& s = out[q.text(0)];
    s.status = q.text(1);
    s.error = q.text(2);
    s.label = q.text(3);
    s.revision = q.text(4);
    s.host_seconds = q.real(5);
    s.finished_at = q.text(6);
    s.job = json::parse(q.text(7), nullptr, false);
  }
  return out;
}

std::vector<json> ResultsStore::rows(const std::string& campaign) const {
  if (!db_) return {};
  Statement q(db_, campaign.empty()
                       ? "SELECT * FROM runs ORDER BY campaign, job_key"
                       : "SELECT * FROM runs WHERE campaign=?1 ORDER BY job_key");
  if (!campaign.empty()) q.bind(1, campaign);
  std::vector<json> out;
  while (q.step()) {
    json row = json::object();
    sqlite3_stmt* s = q.get();
    for (int c = 0; c < sqlite3_column_count(s); ++c) {
      const char* name = sqlite3_column_name(s, c);
      switch (sqlite3_column_type(s, c)) {
        case SQLITE_INTEGER: row[name] = sqlite3_column_int64(s, c); break;
        case SQLITE_FLOAT: row[name] = sqlite3_column_double(s, c); break;
        case SQLITE_NULL: row[name] = nullptr; break;
        default: row[name] = q.text(c); break;
      }
    }
    out.push_back(std::move(row));
  }
  return out;
}

std::vector<std::string> ResultsStore::campaigns() const {
  if (!db_) return {};
  Statement q(db_, "SELECT DISTINCT campaign FROM runs ORDER BY campaign");
  std::vector<std::string> out;
  while (q.step()) out.push_back(q.text(0));
  return out;
}

std::string ResultsStore::integrity_check() const {
  if (!db_) return "ok";
  Statement q(db_, "PRAGMA integrity_check");
  std::string out;
  while (q.step()) out += (out.empty() ? "" : "\n") + q.text(0);
  return out;
}

}  // namespace rtsim
