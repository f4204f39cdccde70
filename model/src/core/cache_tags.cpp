#include <rtsim/model/core/cache_tags.h>
#include <rtsim/workloads/error.h>

#include <algorithm>

namespace rtsim {

namespace {
bool is_power_of_two(uint64_t x) { return x != 0 && (x & (x - 1)) == 0; }
uint32_t log2_exact(uint64_t x) {
  uint32_t s = 0;
  while ((uint64_t(1) << s) < x) ++s;
  return s;
}
}  // namespace

void validate_cache_geometry(const CacheGeometry& g, const std::string& name) {
  if (!is_power_of_two(g.line_bytes))
    throw InputError(name + ".line_bytes", "must be a power of two, got " + std::to_string(g.line_bytes));
  if (g.ways < 1) throw InputError(name + ".ways", "must be at least 1");
  const uint64_t set_bytes = uint64_t(g.line_bytes) * g.ways;
  if (g.size_bytes < set_bytes || g.size_bytes % set_bytes != 0)
    throw InputError(name + ".size_bytes", "must be a whole number (>= 1) of sets of line_bytes x ways = " +
                                               std::to_string(set_bytes) + " bytes");
  if (!is_power_of_two(g.size_bytes / set_bytes))
    throw InputError(name + ".size_bytes", "size / (line_bytes x ways) must be a power of two");
}

CacheTags::CacheTags(const CacheGeometry& geometry, const std::string& name) : geometry_(geometry) {
  validate_cache_geometry(geometry, name);
  sets_ = uint32_t(geometry.size_bytes / (uint64_t(geometry.line_bytes) * geometry.ways));
  line_shift_ = log2_exact(geometry.line_bytes);
  ways_.assign(size_t(sets_) * geometry.ways, Way{});
}

bool CacheTags::lookup(uint64_t address) {
  const uint64_t line = address >> line_shift_;
  Way* set = &ways_[size_t(line & (sets_ - 1)) * geometry_.ways];
  for (uint32_t w = 0; w < geometry_.ways; ++w) {
    if (set[w].last_use != 0 && set[w].tag == line) {
      set[w].last_use = ++clock_;
      return true;
    }
  }
  return false;
}

bool CacheTags::contains(uint64_t address) const {
  const uint64_t line = address >> line_shift_;
  const Way* set = &ways_[size_t(line & (sets_ - 1)) * geometry_.ways];
  for (uint32_t w = 0; w < geometry_.ways; ++w)
    if (set[w].last_use != 0 && set[w].tag == line) return true;
  return false;
}

bool CacheTags::insert(uint64_t address, uint64_t* evicted_line) {
  const uint64_t line = address >> line_shift_;
  Way* set = &ways_[size_t(line & (sets_ - 1)) * geometry_.ways];
  Way* victim = &set[0];
  for (uint32_t w = 0; w < geometry_.ways; ++w) {
    if (set[w].last_use != 0 && set[w].tag == line) {  // already present: refresh only
      set[w].last_use = ++clock_;
      return false;
    }
    // Invalid ways (last_use 0) are the oldest of all, so they are taken first.
    if (set[w].last_use < victim->last_use) victim = &set[w];
  }
  const bool evicts = victim->last_use != 0;
  if (evicts && evicted_line) *evicted_line = victim->tag << line_shift_;
  victim->tag = line;
  victim->last_use = ++clock_;
  return evicts;
}

bool CacheTags::access(uint64_t address) {
  if (lookup(address)) return true;
  insert(address);
  return false;
}

void CacheTags::clear() {
  std::fill(ways_.begin(), ways_.end(), Way{});
  clock_ = 0;
}

FunctionalCacheHierarchy::FunctionalCacheHierarchy(const CacheHierarchyConfig& config)
    : config_(config),
      l1_node_(config.l1_node, "cache.l1_node"),
      l1_triangle_(config.l1_triangle, "cache.l1_triangle"),
      l2_(config.l2, "cache.l2") {}

void FunctionalCacheHierarchy::on_fetch(const Fetch& fetch) {
  if (fetch.bytes == 0) return;
  const bool is_node = fetch.kind == FetchKind::Node;
  CacheTags& l1 = is_node ? l1_node_ : l1_triangle_;
  CacheLevelStats& stats = is_node ? l1_node_stats_ : l1_triangle_stats_;
  const uint64_t line_bytes = l1.geometry().line_bytes;
  const uint64_t end = fetch.address + fetch.bytes;
  for (uint64_t line = l1.line_address(fetch.address); line < end; line += line_bytes) {
    const uint64_t lo = std::max(line, fetch.address), hi = std::min(line + line_bytes, end);
    ++stats.accesses;
    stats.bytes_requested += hi - lo;
    if (l1.access(line)) {
      ++stats.hits;
    } else {
      ++stats.misses;
      stats.bytes_filled += line_bytes;
      access_l2(line, uint32_t(line_bytes), fetch.ray_type);
    }
  }
}

void FunctionalCacheHierarchy::access_l2(uint64_t address, uint32_t bytes, RayType type) {
  const uint64_t line_bytes = l2_.geometry().line_bytes;
  const uint64_t end = address + bytes;
  for (uint64_t line = l2_.line_address(address); line < end; line += line_bytes) {
    const uint64_t lo = std::max(line, address), hi = std::min(line + line_bytes, end);
    ++l2_stats_.accesses;
    l2_stats_.bytes_requested += hi - lo;
    if (l2_.access(line)) {
      ++l2_stats_.hits;
    } else {
      ++l2_stats_.misses;
      l2_stats_.bytes_filled += line_bytes;
      dram_by_type_[ray_type_index(type)] += line_bytes;
    }
  }
}

void FunctionalCacheHierarchy::clear() {
  l1_node_.clear();
  l1_triangle_.clear();
  l2_.clear();
  l1_node_stats_ = l1_triangle_stats_ = l2_stats_ = CacheLevelStats{};
  dram_by_type_.fill(0);
}

}  // namespace rtsim
