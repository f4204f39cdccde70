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
  interleave_shift_ = is_power_of_two(geometry.interleave) ? int(log2_exact(geometry.interleave)) : -1;
  const size_t ways = size_t(sets_) * geometry.ways;
  tags_.assign(ways, kInvalid);
  last_use_.assign(ways, 0);
  ready_ps_.assign(ways, 0);
  dirty_.assign(ways, 0);
}

void CacheTags::set_ready(uint64_t address, uint64_t ready_ps) {
  const size_t way = find(address >> line_shift_);
  if (way != npos) ready_ps_[way] = ready_ps;
}

bool CacheTags::contains(uint64_t address) const { return find(address >> line_shift_) != npos; }

Eviction CacheTags::insert(uint64_t address, bool dirty, RayType writer) {
  const uint8_t mark = dirty ? uint8_t(1 + uint8_t(writer)) : 0;
  const uint64_t line = address >> line_shift_;
  const size_t first = set_start(line);
  size_t victim = first;
  for (size_t w = first; w < first + geometry_.ways; ++w) {
    if (tags_[w] == line) {  // already present: refresh only
      last_use_[w] = ++clock_;
      dirty_[w] = dirty ? mark : dirty_[w];
      return {};
    }
    // Empty ways (last use 0) are the oldest of all, so they are taken first.
    if (last_use_[w] < last_use_[victim]) victim = w;
  }
  Eviction out;
  out.valid = last_use_[victim] != 0;
  out.dirty = out.valid && dirty_[victim];
  out.line = out.valid ? tags_[victim] << line_shift_ : 0;
  if (out.dirty) out.writer = RayType(dirty_[victim] - 1);
  tags_[victim] = line;
  last_use_[victim] = ++clock_;
  ready_ps_[victim] = 0;
  dirty_[victim] = mark;
  return out;
}

bool CacheTags::access(uint64_t address) {
  if (lookup(address)) return true;
  insert(address);
  return false;
}

void CacheTags::clear() {
  std::fill(tags_.begin(), tags_.end(), kInvalid);
  std::fill(last_use_.begin(), last_use_.end(), 0);
  std::fill(ready_ps_.begin(), ready_ps_.end(), 0);
  std::fill(dirty_.begin(), dirty_.end(), 0);
  clock_ = 0;
}

}  // namespace rtsim
