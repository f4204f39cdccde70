#include <rtsim/model/sim/cache_model.h>

namespace rtsim::sim {

const char* data_kind_name(DataKind kind) {
  switch (kind) {
    case DataKind::Node: return "node";
    case DataKind::Triangle: return "triangle";
    case DataKind::Other: return "other";
  }
  return "?";
}

uint64_t TrafficMatrix::total() const {
  uint64_t sum = 0;
  for (auto& row : bytes)
    for (uint64_t v : row) sum += v;
  return sum;
}

void TrafficMatrix::report(StatsRegistry& stats, const std::string& prefix,
                           const std::string& what) const {
  for (RayType type : kAllRayTypes)
    for (int k = 0; k < kDataKindCount; ++k) {
      const uint64_t v = bytes[size_t(type)][size_t(k)];
      if (v == 0) continue;
      stats.set(prefix + "." + ray_type_name(type) + "." + data_kind_name(DataKind(k)), v, "bytes",
                what + " for " + ray_type_name(type) + " rays, " + data_kind_name(DataKind(k)) +
                    " data");
    }
  stats.set(prefix + ".total", total(), "bytes", what + ", all ray types and kinds");
}

CacheModel::CacheModel(const CacheConfig& config, const std::string& name)
    : config_(config),
      tags_(CacheGeometry{config.size_bytes, config.line_bytes, config.associativity}, name) {}

bool CacheModel::access(const LineAccess& a) {
  ++counters_.accesses;
  requested_.add(a.ray_type, a.kind, a.bytes);
  if (tags_.access(a.line)) {
    ++counters_.hits;
    return true;
  }
  ++counters_.misses;
  filled_.add(a.ray_type, a.kind, config_.line_bytes);
  return false;
}

CacheModel::Outcome CacheModel::request(const LineAccess& a) {
  if (tags_.lookup(a.line)) {
    ++counters_.accesses;
    ++counters_.hits;
    requested_.add(a.ray_type, a.kind, a.bytes);
    return Outcome::Hit;
  }
  auto it = mshr_.find(a.line);
  if (it != mshr_.end()) {
    ++counters_.accesses;
    ++counters_.mshr_merges;
    ++it->second;
    requested_.add(a.ray_type, a.kind, a.bytes);
    return Outcome::Merged;
  }
  if (mshr_.size() >= config_.mshrs) {
    ++counters_.mshr_full_stalls;  // not an access yet: the requester retries
    return Outcome::Blocked;
  }
  ++counters_.accesses;
  ++counters_.misses;
  requested_.add(a.ray_type, a.kind, a.bytes);
  filled_.add(a.ray_type, a.kind, config_.line_bytes);
  mshr_.emplace(a.line, 1);
  return Outcome::Miss;
}

void CacheModel::fill(uint64_t line) {
  tags_.insert(line);
  mshr_.erase(line);
}

namespace {
void report_counters(StatsRegistry& s, const std::string& prefix, const CacheModel::Counters& c,
                     const TrafficMatrix& requested, const TrafficMatrix& filled) {
  s.set(prefix + ".accesses", c.accesses, "requests", "line requests to this cache");
  s.set(prefix + ".hits", c.hits, "requests", "requests that found their line");
  s.set(prefix + ".misses", c.misses, "requests", "requests that allocated an MSHR and went on");
  s.set(prefix + ".mshr_merges", c.mshr_merges, "requests",
        "requests merged into an outstanding miss to the same line");
  s.set(prefix + ".mshr_full_stalls", c.mshr_full_stalls, "events",
        "requests refused for a while because every MSHR was busy");
  s.set_real(prefix + ".hit_rate", c.accesses ? double(c.hits) / double(c.accesses) : 0.0,
             "ratio", "hits / accesses");
  requested.report(s, prefix + ".bytes_requested", "bytes asked of this cache");
  filled.report(s, prefix + ".bytes_filled", "bytes this cache read from the next level");
}
}  // namespace

void CacheModel::report(StatsRegistry& s, const std::string& prefix) const {
  report_counters(s, prefix, counters_, requested_, filled_);
}

void report_cache_group(StatsRegistry& s, const std::string& prefix,
                        const std::vector<const CacheModel*>& caches) {
  CacheModel::Counters sum;
  TrafficMatrix requested, filled;
  for (const CacheModel* c : caches) {
    const auto& k = c->counters();
    sum.accesses += k.accesses, sum.hits += k.hits, sum.misses += k.misses;
    sum.mshr_merges += k.mshr_merges, sum.mshr_full_stalls += k.mshr_full_stalls;
    for (size_t t = 0; t < kRayTypeCount; ++t)
      for (size_t d = 0; d < kDataKindCount; ++d) {
        requested.bytes[t][d] += c->requested().bytes[t][d];
        filled.bytes[t][d] += c->filled().bytes[t][d];
      }
  }
  report_counters(s, prefix, sum, requested, filled);
  s.set(prefix + ".instances", caches.size(), "caches", "caches summed here");
}

}  // namespace rtsim::sim
