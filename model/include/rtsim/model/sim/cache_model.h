#pragma once
// One cache level of the timing model: the functional core's CacheTags (the one
// tag implementation) plus what timing needs around it - MSHR bookkeeping, hit /
// miss / merge counters, and every byte attributed to (ray type, data kind).
#include <rtsim/model/core/cache_tags.h>
#include <rtsim/model/core/fetch.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stats.h>

#include <array>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace rtsim::sim {

// Data kinds the byte attribution uses: BVH nodes, triangles, and everything else
// (leaf prim-ref lists, spilled traversal stack entries).
enum class DataKind : uint8_t { Node = 0, Triangle = 1, Other = 2 };
constexpr int kDataKindCount = 3;
const char* data_kind_name(DataKind kind);
inline DataKind data_kind_of(FetchKind kind) {
  return kind == FetchKind::Node ? DataKind::Node
                                 : kind == FetchKind::Triangle ? DataKind::Triangle
                                                               : DataKind::Other;
}

// Bytes by (ray type, data kind).
struct TrafficMatrix {
  std::array<std::array<uint64_t, kDataKindCount>, kRayTypeCount> bytes{};
  void add(RayType type, DataKind kind, uint64_t n) { bytes[size_t(type)][size_t(kind)] += n; }
  uint64_t total() const;
  // <prefix>.<ray type>.<kind> for every non-zero cell, plus <prefix>.total.
  void report(StatsRegistry& stats, const std::string& prefix, const std::string& what) const;
};

// One line-sized request as the caches see it.
struct LineAccess {
  uint64_t line = 0;     // line-aligned address at this level
  uint32_t bytes = 0;    // bytes of the line the requester wants
  DataKind kind = DataKind::Node;
  RayType ray_type = RayType::Primary;
};

class CacheModel {
 public:
  CacheModel(const CacheConfig& config, const std::string& name);

  const CacheConfig& config() const { return config_; }
  uint64_t line_of(uint64_t address) const { return tags_.line_address(address); }

  // Functional / loosely timed: look up, fill on a miss at once. Returns hit.
  bool access(const LineAccess& a);

  // Cycle level: lookup only; a miss either merges into an MSHR (returns Merged),
  // allocates one (Miss) or finds them all busy (Blocked: retry later).
  enum class Outcome { Hit, Miss, Merged, Blocked };
  Outcome request(const LineAccess& a);
  // The missing line arrived: installs it and frees its MSHR.
  void fill(uint64_t line);
  uint32_t mshrs_in_use() const { return uint32_t(mshr_.size()); }

  struct Counters {
    uint64_t accesses = 0, hits = 0, misses = 0, mshr_merges = 0, mshr_full_stalls = 0;
  };
  const Counters& counters() const { return counters_; }
  const TrafficMatrix& requested() const { return requested_; }  // bytes asked of this level
  const TrafficMatrix& filled() const { return filled_; }        // bytes read from the next level
  void report(StatsRegistry& stats, const std::string& prefix) const;

 private:
  CacheConfig config_;
  CacheTags tags_;
  Counters counters_;
  TrafficMatrix requested_, filled_;
  std::unordered_map<uint64_t, uint32_t> mshr_;  // line -> requests waiting
};

// Sums several same-role caches (e.g. every TRV unit's L1) for the summary stats.
void report_cache_group(StatsRegistry& stats, const std::string& prefix,
                        const std::vector<const CacheModel*>& caches);

}  // namespace rtsim::sim
