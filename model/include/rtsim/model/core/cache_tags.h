#pragma once
// Cache tag logic (no data, no timing): set-associative, LRU, write-back (a
// dirty bit per line). The one tag implementation; the memory hierarchy of every
// fidelity level (model/sim/cache_model.h) keeps its counts around it.
#include <rtsim/model/core/ray.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

struct CacheGeometry {
  uint64_t size_bytes = 16 * 1024;
  uint32_t line_bytes = 64;
  uint32_t ways = 4;  // size / (line * ways) sets, a power of two
  // An L2 slice of N sees every Nth line only: its sets are indexed by line / N,
  // so that all of them are used.
  uint32_t interleave = 1;
};

// Throws InputError("<name>.<field>: reason") unless line and set counts are powers
// of two, ways >= 1 and size is a whole number of sets.
void validate_cache_geometry(const CacheGeometry& geometry, const std::string& name);

// A line that had to leave the cache to make room.
struct Eviction {
  bool valid = false;  // a valid line was replaced
  bool dirty = false;  // it was written: the next level must receive it (write back)
  uint64_t line = 0;   // its byte address
  RayType writer = RayType::Primary;  // dirty: the ray type of its last write (who the write-back is charged to)
};

class CacheTags {
 public:
  explicit CacheTags(const CacheGeometry& geometry, const std::string& name = "cache");

  const CacheGeometry& geometry() const { return geometry_; }
  uint32_t sets() const { return sets_; }
  uint64_t line_address(uint64_t address) const { return address & ~uint64_t(geometry_.line_bytes - 1); }

  // Hit: the line becomes most recently used (and dirty when make_dirty, written by
  // a ray of type `writer`), and *ready_ps (if given) says when its data is there
  // (set_ready; 0 = always was). Miss: nothing changes.
  bool lookup(uint64_t address, bool make_dirty = false, uint64_t* ready_ps = nullptr,
              RayType writer = RayType::Primary);
  // A timed model's note of when a present line's data arrives (its fill).
  void set_ready(uint64_t address, uint64_t ready_ps);
  // Present? No LRU update.
  bool contains(uint64_t address) const;
  // Installs the line (most recently used, dirty if asked: written by `writer`) and
  // says which line it replaced. Inserting a present line only refreshes it (dirty
  // stays or is set).
  Eviction insert(uint64_t address, bool dirty = false, RayType writer = RayType::Primary);
  // lookup, and insert on a miss; returns hit.
  bool access(uint64_t address);
  void clear();

 private:
  // The ways' fields in separate arrays, so that a lookup scans a set's tags in
  // one or two host cache lines (a miss scans them twice: lookup, then insert).
  static constexpr uint64_t kInvalid = ~uint64_t(0);  // no line number is all ones
  size_t find(uint64_t line) const;  // way index, or npos
  size_t set_start(uint64_t line) const {
    // A shift when the interleave is a power of two (always for an L1): a division
    // on every lookup was the functional level's costliest instruction.
    const uint64_t index = interleave_shift_ >= 0 ? line >> interleave_shift_ : line / geometry_.interleave;
    return size_t(index & (sets_ - 1)) * geometry_.ways;
  }
  static constexpr size_t npos = ~size_t(0);
  CacheGeometry geometry_;
  uint32_t sets_;
  uint32_t line_shift_;
  int interleave_shift_;  // log2(interleave), or -1 when it is not a power of two
  uint64_t clock_ = 0;
  std::vector<uint64_t> tags_;      // sets_ x ways; kInvalid = empty way
  std::vector<uint64_t> last_use_;  // LRU clock; 0 = empty way
  std::vector<uint64_t> ready_ps_;  // when the data arrives (timed models)
  // 0: clean; else 1 + the RayType of the last write (one byte a line, as the bit was).
  std::vector<uint8_t> dirty_;
};

// The hit path is inline: every line access of every level asks it.
inline size_t CacheTags::find(uint64_t line) const {
  // Every way is compared, without an early exit: which way hits is random, so a
  // branch on it mispredicts; a line is in at most one way.
  const size_t first = set_start(line);
  const uint64_t* set = &tags_[first];
  size_t way = npos;
  for (uint32_t w = 0; w < geometry_.ways; ++w) way = set[w] == line ? first + w : way;
  return way;
}

inline bool CacheTags::lookup(uint64_t address, bool make_dirty, uint64_t* ready_ps, RayType writer) {
  const size_t way = find(address >> line_shift_);
  if (way == npos) return false;
  last_use_[way] = ++clock_;
  dirty_[way] = make_dirty ? uint8_t(1 + uint8_t(writer)) : dirty_[way];
  if (ready_ps) *ready_ps = ready_ps_[way];
  return true;
}

}  // namespace rtsim
