#include <rtsim/model/sim/cache_model.h>

#include <algorithm>
#include <cmath>

namespace rtsim::sim {

namespace {
// How late (behind the newest) a port request may come and still find its slot.
constexpr uint64_t kPortHorizonPs = 8'000'000;
}  // namespace

uint64_t TrafficMatrix::total() const {
  uint64_t sum = 0;
  for (auto& row : bytes)
    for (uint64_t v : row) sum += v;
  return sum;
}

void TrafficMatrix::add(const TrafficMatrix& o) {
  for (size_t t = 0; t < kRayTypeCount; ++t)
    for (size_t k = 0; k < kAccessKindCount; ++k) bytes[t][k] += o.bytes[t][k];
}

void TrafficMatrix::report(StatsRegistry& stats, const std::string& prefix,
                           const std::string& what) const {
  for (RayType type : kAllRayTypes)
    for (int k = 0; k < kAccessKindCount; ++k) {
      const uint64_t v = bytes[size_t(type)][size_t(k)];
      if (v == 0) continue;
      const char* kind = access_kind_name(AccessKind(k));
      stats.set(prefix + "." + ray_type_name(type) + "." + kind, v, "bytes",
                what + " for " + ray_type_name(type) + " rays, " + kind + " data");
    }
  stats.set(prefix + ".total", total(), "bytes", what + ", all ray types and kinds");
}

void CacheModel::Counters::add(const Counters& o) {
  accesses += o.accesses, hits += o.hits, misses += o.misses, mshr_merges += o.mshr_merges;
  mshr_full_stalls += o.mshr_full_stalls, writes += o.writes, writebacks += o.writebacks;
  port_wait_ps += o.port_wait_ps;
  for (size_t t = 0; t < kRayTypeCount; ++t)
    timed_reads[t] += o.timed_reads[t], read_latency_ps[t] += o.read_latency_ps[t];
}

CacheModel::CacheModel(const CacheConfig& config, const std::string& name, uint64_t cycle_ps)
    : config_(config),
      tags_(CacheGeometry{config.size_bytes, config.line_bytes, config.associativity,
                          config.interleave},
            name),
      hit_ps_(uint64_t(config.hit_latency_cycles) * cycle_ps),
      fill_ps_(uint64_t(config.fill_latency_cycles) * cycle_ps),
      ports_(std::max<uint64_t>(1, cycle_ps / std::max<uint32_t>(1, config.ports)), kPortHorizonPs),
      cycle_ps_(cycle_ps) {
}

Eviction CacheModel::install(uint64_t line, bool dirty, RayType writer) {
  const Eviction e = tags_.insert(line, dirty, writer);
  if (e.dirty) ++counters_.writebacks;
  return e;
}

void CacheModel::set_arrival(uint64_t line, uint64_t ready_ps) { tags_.set_ready(line, ready_ps); }

CacheModel::Result CacheModel::request_missing(const LineAccess& a) {
  Result r;
  auto it = mshr_.find(a.line);
  if (it != mshr_.end()) {
    ++it->second.waiting;
    if (a.write) it->second.dirty_on_fill = true, it->second.writer = a.ray_type;
    r.outcome = Outcome::Merged;
    count(a, r.outcome);
    return r;
  }
  if (a.write) {
    // Write-allocate without a fill: the line is there at once, dirty.
    r.outcome = Outcome::Miss;
    r.writeback = install(a.line, true, a.ray_type);
    count(a, r.outcome);
    return r;
  }
  if (mshr_.size() >= config_.mshrs) {
    ++counters_.mshr_full_stalls;  // not an access yet: the requester retries
    r.outcome = Outcome::Blocked;
    return r;
  }
  r.outcome = Outcome::Miss;
  r.fetch = true;
  filled_.add(a.ray_type, a.kind, config_.line_bytes);
  mshr_.emplace(a.line, Mshr{1, false, RayType::Primary});
  count(a, r.outcome);
  return r;
}

Eviction CacheModel::fill(uint64_t line) {
  auto it = mshr_.find(line);
  const bool dirty = it != mshr_.end() && it->second.dirty_on_fill;
  const RayType writer = it != mshr_.end() ? it->second.writer : RayType::Primary;
  if (it != mshr_.end()) mshr_.erase(it);
  return install(line, dirty, writer);
}

void CacheModel::reset_counters() {
  counters_ = Counters{};
  requested_ = filled_ = TrafficMatrix{};
}

namespace {
void report_counters(StatsRegistry& s, const std::string& prefix, const CacheModel::Counters& c,
                     const TrafficMatrix& requested, const TrafficMatrix& filled,
                     uint32_t line_bytes, double cycle_ps) {
  const double accesses = double(std::max<uint64_t>(1, c.accesses));
  s.set(prefix + ".accesses", c.accesses, "requests",
        "line requests to this cache (hits + misses + MSHR merges)");
  s.set(prefix + ".hits", c.hits, "requests", "requests that found their line present");
  s.set(prefix + ".misses", c.misses, "requests",
        "requests whose line was absent (reads went on to the next level)");
  s.set(prefix + ".mshr_merges", c.mshr_merges, "requests",
        "reads of a line whose fill was still on its way (merged into its miss)");
  s.set_real(prefix + ".hit_rate", c.accesses ? double(c.hits) / accesses : 0.0, "ratio",
             "hits / accesses");
  s.set_real(prefix + ".mshr_merge_rate", c.accesses ? double(c.mshr_merges) / accesses : 0.0,
             "ratio", "MSHR merges / accesses");
  s.set(prefix + ".mshr_full_stalls", c.mshr_full_stalls, "events",
        "misses that waited because every MSHR was busy");
  s.set(prefix + ".writes", c.writes, "requests", "write requests (stack spills, write-backs)");
  s.set(prefix + ".writebacks", c.writebacks, "lines", "dirty lines written to the next level");
  s.set(prefix + ".bytes_written_back", c.writebacks * line_bytes, "bytes",
        "bytes of dirty lines written to the next level");
  s.set(prefix + ".port_wait_cycles", uint64_t(std::llround(double(c.port_wait_ps) / cycle_ps)),
        "cycles", "summed waiting of requests for a free port (lt and cycle)");
  requested.report(s, prefix + ".bytes_requested", "bytes asked of this cache");
  filled.report(s, prefix + ".bytes_filled", "bytes this cache read from the next level");
  // Average memory access time, where time is modelled (lt and cycle).
  uint64_t reads = 0, latency_ps = 0;
  for (size_t t = 0; t < kRayTypeCount; ++t) reads += c.timed_reads[t], latency_ps += c.read_latency_ps[t];
  if (reads == 0) return;
  s.set_real(prefix + ".amat", double(latency_ps) / double(reads) / cycle_ps, "cycles",
             "average memory access time of this level: mean cycles from a read reaching it to its "
             "data leaving it (hits: port wait and hit latency; misses and merges: until the fill)");
  for (RayType type : kAllRayTypes) {
    const size_t t = size_t(type);
    if (c.timed_reads[t] == 0) continue;
    s.set_real(prefix + ".amat_by_type." + ray_type_name(type),
               double(c.read_latency_ps[t]) / double(c.timed_reads[t]) / cycle_ps, "cycles",
               std::string("average memory access time of this level for the reads of ") + ray_type_name(type) +
                   " rays");
  }
}
}  // namespace

void CacheModel::report(StatsRegistry& s, const std::string& prefix) const {
  report_counters(s, prefix, counters_, requested_, filled_, config_.line_bytes, double(cycle_ps_));
}

void report_cache_group(StatsRegistry& s, const std::string& prefix,
                        const std::vector<const CacheModel*>& caches) {
  CacheModel::Counters sum;
  TrafficMatrix requested, filled;
  for (const CacheModel* c : caches) {
    sum.add(c->counters());
    requested.add(c->requested());
    filled.add(c->filled());
  }
  const CacheModel& first = *caches.front();
  report_counters(s, prefix, sum, requested, filled, first.config().line_bytes,
                  double(first.cycle_ps()));
  s.set(prefix + ".instances", caches.size(), "caches", "caches summed here");
}

}  // namespace rtsim::sim
