#pragma once
// One cache level of the memory hierarchy, at every fidelity level: the core's
// CacheTags (the one tag implementation) plus MSHR bookkeeping, port timing, and
// one accounting everywhere:
//   accesses = hits + misses + mshr_merges   (a request refused for want of an
//                                             MSHR retries and is counted once)
//   hit_rate = hits / accesses;  mshr_merge_rate = mshr_merges / accesses
// A merge is a read of a line whose fill is still on its way. The functional
// level has no time, so it has no merges; lt and cycle do.
// Policy: write-back, write-allocate without a fill (a write miss installs the
// line dirty, as a cache with byte masks does); a dirty line that leaves is
// written to the next level.
#include <rtsim/model/core/cache_tags.h>
#include <rtsim/model/core/fetch.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/port_slots.h>
#include <rtsim/model/sim/stats.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <unordered_map>
#include <vector>

namespace rtsim::sim {

// Bytes by (ray type, access kind).
struct TrafficMatrix {
  std::array<std::array<uint64_t, kAccessKindCount>, kRayTypeCount> bytes{};
  void add(RayType type, AccessKind kind, uint64_t n) { bytes[size_t(type)][size_t(kind)] += n; }
  uint64_t total() const;
  void add(const TrafficMatrix& o);
  // <prefix>.<ray type>.<kind> for every non-zero cell, plus <prefix>.total.
  void report(StatsRegistry& stats, const std::string& prefix, const std::string& what) const;
};

// One line-sized request as the caches see it.
struct LineAccess {
  uint64_t line = 0;     // line-aligned address at this level
  uint32_t bytes = 0;    // bytes of the line the requester wants
  AccessKind kind = AccessKind::Node;
  RayType ray_type = RayType::Primary;
  bool write = false;
};

class CacheModel {
 public:
  CacheModel(const CacheConfig& config, const std::string& name, uint64_t cycle_ps = 1000);

  const CacheConfig& config() const { return config_; }
  uint64_t line_of(uint64_t address) const { return tags_.line_address(address); }

  enum class Outcome { Hit, Miss, Merged, Blocked };
  struct Result {
    Outcome outcome = Outcome::Hit;
    bool fetch = false;      // a read miss: the caller must read the line from the next level
    Eviction writeback;      // a dirty line that left: the caller writes it to the next level
    uint64_t ready_ps = 0;   // Merged (lt): when the line's data arrives
  };

  // Functional / lt: a miss installs the line at once (the caller fetches it);
  // lt then says when the data arrives (set_arrival), and reads before that merge.
  Result access(const LineAccess& a, uint64_t now_ps = 0);
  void set_arrival(uint64_t line, uint64_t ready_ps);

  // Cycle: a read miss merges into the line's MSHR, allocates one (Miss), or
  // finds them all busy (Blocked: retry later, not counted yet).
  Result request(const LineAccess& a);  // inline: a hit calls nothing
  // The missing line arrived: installs it and frees its MSHR.
  Eviction fill(uint64_t line);
  uint32_t mshrs_in_use() const { return uint32_t(mshr_.size()); }
  // lt: a miss waited for a free MSHR (the cycle level counts its refusals itself).
  void note_mshr_wait() { ++counters_.mshr_full_stalls; }
  // Timed levels: a read of this ray type took this long from reaching the cache to
  // its data leaving it (hit: port wait + hit latency; miss or merge: until the fill).
  void note_read_latency(RayType type, uint64_t ps) {
    ++counters_.timed_reads[size_t(type)];
    counters_.read_latency_ps[size_t(type)] += ps;
  }

  // Ports: config.ports accesses per cycle. Returns when an access arriving at
  // t_ps is served, and takes its slot.
  uint64_t reserve_port(uint64_t t_ps);
  uint64_t hit_latency_ps() const { return hit_ps_; }
  uint64_t fill_latency_ps() const { return fill_ps_; }
  uint64_t cycle_ps() const { return cycle_ps_; }

  struct Counters {
    uint64_t accesses = 0, hits = 0, misses = 0, mshr_merges = 0, mshr_full_stalls = 0;
    uint64_t writes = 0, writebacks = 0, port_wait_ps = 0;
    // Timed levels: reads answered and their time from reaching this cache to their
    // data leaving it (the level's average memory access time), by ray type.
    std::array<uint64_t, kRayTypeCount> timed_reads{}, read_latency_ps{};
    void add(const Counters& o);
  };
  const Counters& counters() const { return counters_; }
  const TrafficMatrix& requested() const { return requested_; }  // bytes asked of this level
  const TrafficMatrix& filled() const { return filled_; }        // bytes read from the next level
  // Frames: counts start again; tags, MSHRs and port state stay.
  void reset_counters();
  // Sees every access when it is counted (a request refused for want of an MSHR when
  // it is finally taken), with its outcome: what a cache trace records.
  void set_access_observer(std::function<void(const LineAccess&, Outcome)> observer) {
    observer_ = std::move(observer);
  }
  void report(StatsRegistry& stats, const std::string& prefix) const;

 private:
  void count(const LineAccess& a, Outcome outcome);
  Result request_missing(const LineAccess& a);  // request() of a line not present
  Eviction install(uint64_t line, bool dirty, RayType writer);

  CacheConfig config_;
  CacheTags tags_;
  uint64_t hit_ps_, fill_ps_;
  PortSlots ports_;
  uint64_t cycle_ps_;
  Counters counters_;
  TrafficMatrix requested_, filled_;
  struct Mshr {
    uint32_t waiting = 0;
    bool dirty_on_fill = false;  // a write met the line while its fill was on the way
    RayType writer = RayType::Primary;  // ... of this ray type
  };
  std::unordered_map<uint64_t, Mshr> mshr_;  // cycle: missing lines
  std::function<void(const LineAccess&, Outcome)> observer_;
};

// Inline: every line access of the functional and lt levels passes here.
inline void CacheModel::count(const LineAccess& a, Outcome outcome) {
  ++counters_.accesses;
  if (a.write) ++counters_.writes;
  requested_.add(a.ray_type, a.kind, a.bytes);
  switch (outcome) {
    case Outcome::Hit: ++counters_.hits; break;
    case Outcome::Miss: ++counters_.misses; break;
    case Outcome::Merged: ++counters_.mshr_merges; break;
    case Outcome::Blocked: break;
  }
  if (observer_) observer_(a, outcome);
}

inline CacheModel::Result CacheModel::access(const LineAccess& a, uint64_t now_ps) {
  Result r;
  uint64_t ready = 0;
  if (tags_.lookup(a.line, a.write, &ready, a.ray_type)) {
    // lt: a read of a line whose fill has not landed yet merges and waits for it.
    r.outcome = ready > now_ps && !a.write ? Outcome::Merged : Outcome::Hit;
    r.ready_ps = ready;
    count(a, r.outcome);
    return r;
  }
  r.outcome = Outcome::Miss;
  r.fetch = !a.write;
  if (r.fetch) filled_.add(a.ray_type, a.kind, config_.line_bytes);
  r.writeback = install(a.line, a.write, a.ray_type);
  count(a, r.outcome);
  return r;
}

inline CacheModel::Result CacheModel::request(const LineAccess& a) {
  if (!tags_.lookup(a.line, a.write, nullptr, a.ray_type)) return request_missing(a);
  count(a, Outcome::Hit);
  return Result{};
}

inline uint64_t CacheModel::reserve_port(uint64_t t_ps) {
  // Port slots of one interval each. Requests come nearly in time order, but one
  // that waited upstream (an MSHR, say) may come after later ones: it takes the
  // first free slot from its own time on, not the slot after the latest taken.
  const uint64_t slot = t_ps / ports_.interval_ps();
  if (ports_.forgotten(slot)) return t_ps;  // the ring is far longer than any request waits
  const uint64_t free = ports_.first_free(slot);
  ports_.take(free);
  const uint64_t start = std::max(t_ps, free * ports_.interval_ps());
  counters_.port_wait_ps += start - t_ps;
  return start;
}

// Sums several same-role caches (e.g. every TRV unit's L1) for the summary stats.
void report_cache_group(StatsRegistry& stats, const std::string& prefix,
                        const std::vector<const CacheModel*>& caches);

}  // namespace rtsim::sim
