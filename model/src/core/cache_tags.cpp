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

CacheTags::Way* CacheTags::find(uint64_t line) {
  Way* set = &ways_[size_t(line & (sets_ - 1)) * geometry_.ways];
  for (uint32_t w = 0; w < geometry_.ways; ++w)
    if (set[w].last_use != 0 && set[w].tag == line) return &set[w];
  return nullptr;
}

bool CacheTags::lookup(uint64_t address, bool make_dirty) {
  Way* way = find(address >> line_shift_);
  if (!way) return false;
  way->last_use = ++clock_;
  way->dirty = way->dirty || make_dirty;
  return true;
}

bool CacheTags::contains(uint64_t address) const {
  return const_cast<CacheTags*>(this)->find(address >> line_shift_) != nullptr;
}

Eviction CacheTags::insert(uint64_t address, bool dirty) {
  const uint64_t line = address >> line_shift_;
  Way* set = &ways_[size_t(line & (sets_ - 1)) * geometry_.ways];
  Way* victim = &set[0];
  for (uint32_t w = 0; w < geometry_.ways; ++w) {
    if (set[w].last_use != 0 && set[w].tag == line) {  // already present: refresh only
      set[w].last_use = ++clock_;
      set[w].dirty = set[w].dirty || dirty;
      return {};
    }
    // Invalid ways (last_use 0) are the oldest of all, so they are taken first.
    if (set[w].last_use < victim->last_use) victim = &set[w];
  }
  Eviction out;
  out.valid = victim->last_use != 0;
  out.dirty = out.valid && victim->dirty;
  out.line = victim->tag << line_shift_;
  victim->tag = line;
  victim->last_use = ++clock_;
  victim->dirty = dirty;
  return out;
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

}  // namespace rtsim
