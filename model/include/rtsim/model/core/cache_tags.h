#pragma once
// Cache tag logic (no data, no timing): set-associative, LRU. The one
// implementation used by the functional cache simulator and, inside timing
// wrappers, by the SystemC caches.
#include <rtsim/model/core/fetch.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

struct CacheGeometry {
  uint64_t size_bytes = 16 * 1024;
  uint32_t line_bytes = 64;
  uint32_t ways = 4;  // size / (line * ways) sets, a power of two
};

// Throws InputError("<name>.<field>: reason") unless line and set counts are powers
// of two, ways >= 1 and size is a whole number of sets.
void validate_cache_geometry(const CacheGeometry& geometry, const std::string& name);

class CacheTags {
 public:
  explicit CacheTags(const CacheGeometry& geometry, const std::string& name = "cache");

  const CacheGeometry& geometry() const { return geometry_; }
  uint32_t sets() const { return sets_; }
  uint64_t line_address(uint64_t address) const { return address & ~uint64_t(geometry_.line_bytes - 1); }

  // Hit: the line becomes most recently used. Miss: nothing changes.
  bool lookup(uint64_t address);
  // Present? No LRU update.
  bool contains(uint64_t address) const;
  // Installs the line (most recently used). If a valid line had to go, returns
  // true and its byte address in *evicted_line. Inserting a present line only
  // refreshes it.
  bool insert(uint64_t address, uint64_t* evicted_line = nullptr);
  // lookup, and insert on a miss; returns hit.
  bool access(uint64_t address);
  void clear();

 private:
  struct Way {
    uint64_t tag = 0;
    uint64_t last_use = 0;  // 0 = invalid
  };
  CacheGeometry geometry_;
  uint32_t sets_;
  uint32_t line_shift_;
  uint64_t clock_ = 0;
  std::vector<Way> ways_;  // sets_ x geometry_.ways
};

struct CacheLevelStats {
  uint64_t accesses = 0;  // line accesses
  uint64_t hits = 0;
  uint64_t misses = 0;
  uint64_t bytes_requested = 0;  // bytes asked of this level
  uint64_t bytes_filled = 0;     // bytes this level read from the next (misses x line)
  double hit_rate() const { return accesses ? double(hits) / double(accesses) : 0.0; }
  void add(const CacheLevelStats& o) {
    accesses += o.accesses;
    hits += o.hits;
    misses += o.misses;
    bytes_requested += o.bytes_requested;
    bytes_filled += o.bytes_filled;
  }
};

struct CacheHierarchyConfig {
  CacheGeometry l1_node{16 * 1024, 64, 4};
  CacheGeometry l1_triangle{16 * 1024, 64, 4};  // prim refs and triangles
  CacheGeometry l2{512 * 1024, 64, 8};           // shared; its misses go to DRAM
};

// Functional memory hierarchy fed by the traversal's fetches (in a fixed order,
// so hit rates are deterministic): node fetches go to the L1 node cache, prim-ref
// and triangle fetches to the L1 triangle cache, both L1s miss into a shared L2.
// A fetch that spans several lines is one access per line.
class FunctionalCacheHierarchy : public FetchSink {
 public:
  explicit FunctionalCacheHierarchy(const CacheHierarchyConfig& config = {});
  void on_fetch(const Fetch& fetch) override;

  const CacheHierarchyConfig& config() const { return config_; }
  const CacheLevelStats& l1_node() const { return l1_node_stats_; }
  const CacheLevelStats& l1_triangle() const { return l1_triangle_stats_; }
  const CacheLevelStats& l2() const { return l2_stats_; }
  // Bytes by ray type read from DRAM (L2 fills), and asked of L1.
  uint64_t dram_bytes() const { return l2_stats_.bytes_filled; }
  const std::array<uint64_t, kRayTypeCount>& dram_bytes_by_ray_type() const { return dram_by_type_; }
  void clear();

 private:
  void access_l2(uint64_t line_address, uint32_t bytes, RayType type);
  CacheHierarchyConfig config_;
  CacheTags l1_node_, l1_triangle_, l2_;
  CacheLevelStats l1_node_stats_, l1_triangle_stats_, l2_stats_;
  std::array<uint64_t, kRayTypeCount> dram_by_type_{};
};

}  // namespace rtsim
