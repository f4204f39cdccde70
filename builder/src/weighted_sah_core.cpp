#include "weighted_sah_core.h"

#include "treelet.h"
#include "triangle_clip.h"

#include <rtsim/builder/metrics.h>

#include <rtsim/workloads/error.h>

#include <tbb/concurrent_vector.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

// RTSIM_SIMD=OFF (RTSIM_NO_SIMD) builds the scalar fallback of the bin sweep, as on a
// machine without SSE2: the same trees, bit for bit.
#if defined(__SSE2__) && !defined(RTSIM_NO_SIMD)
#define RTSIM_SAH_SSE2 1
#include <emmintrin.h>
#endif

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <new>
#include <string>

namespace rtsim::detail {

uint32_t levels_needed(uint64_t n, uint32_t max_leaf) {
  if (n <= max_leaf) return 0;
  uint64_t leaves = (n + max_leaf - 1) / max_leaf;
  uint32_t levels = 0;
  while ((uint64_t(1) << levels) < leaves) ++levels;
  return levels;
}

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
// A reference packs its triangle index, the OSAH visibility flag and how often it
// was split (SBVH) into one word, so that a reference stays 32 bytes (binning is
// memory-bound).
constexpr uint32_t kPrimMask = 0x0FFF'FFFFu;
constexpr uint32_t kSplitShift = 28;
constexpr uint32_t kSplitMask = 0x7000'0000u;
constexpr uint32_t kVisibleBit = 0x8000'0000u;
constexpr uint32_t kMaxBins = 256;
// Nodes with more references than this bin in fixed-size chunks in parallel and
// recurse into their children in parallel.
constexpr uint32_t kChunk = 16384;
constexpr uint32_t kParallelRecursion = 4096;
// Nodes with at most this many references are split by an exact sweep.
constexpr uint32_t kExactSweepBelow = 32;
// SBVH, the quality builder, sweeps exactly up to larger nodes: 32 bins cost it
// 3.5% on foliage against the full sweep, and nodes of <= 256 references recover
// nearly all of that (docs/build-speed.md, SBVH).
constexpr uint32_t kExactSweepBelowSpatial = 256;

struct Ref {
  vec3 lo;
  uint32_t tag;
  vec3 hi;
  float weight;
  uint32_t prim() const { return tag & kPrimMask; }
  uint32_t visible() const { return (tag & kVisibleBit) ? 1u : 0u; }
  uint32_t splits() const { return (tag & kSplitMask) >> kSplitShift; }
  // Twice the box centre: binning needs only an affine map of it.
  float centroid2(int axis) const { return lo[axis] + hi[axis]; }
  Aabb box() const { return Aabb{lo, hi}; }
};
static_assert(sizeof(Ref) == 32, "a reference should stay 32 bytes");

// A strict order of references by their geometry alone: box, then the triangle's
// vertices (two halves of a quad share a box), and only for exact duplicates the
// index. Every sort and tie of the builder goes through it, so the tree does not
// depend on the input's face order.
bool ref_geometric_less(const Scene& scene, const Ref& a, const Ref& b) {
  for (int k = 0; k < 3; ++k) {
    if (a.lo[k] != b.lo[k]) return a.lo[k] < b.lo[k];
    if (a.hi[k] != b.hi[k]) return a.hi[k] < b.hi[k];
  }
  if (a.prim() == b.prim()) return false;
  return triangle_geometric_less(scene, a.prim(), b.prim());
}

// Along an axis: the centroid, then the geometric order.
struct RefLess {
  const Scene* scene;
  int axis;
  bool operator()(const Ref& a, const Ref& b) const {
    const float ca = a.centroid2(axis), cb = b.centroid2(axis);
    if (ca != cb) return ca < cb;
    return ref_geometric_less(*scene, a, b);
  }
};

struct NodeInfo {  // summed by NodeInfoLanes
  Aabb box;
  Aabb centroids;  // of centroid2 (twice the centre)
  float weight = 0;
  uint32_t visible = 0;
  uint32_t count = 0;
};

struct Split {
  enum class Kind { None, Object, Sweep, Spatial } kind = Kind::None;
  int axis = -1;
  uint32_t bin = 0;   // object/spatial: split after this bin; sweep: left count - 1
  float position = 0;  // spatial: the split plane
  float cost = kInf;
  uint32_t left_count = 0, right_count = 0;  // spatial: upper bounds before unsplitting
  uint32_t left_visible = 0, right_visible = 0;  // visible references (spatial: as the counts)
  Aabb left_box, right_box;
  float left_weight = 0, right_weight = 0;
  bool visibility = false;  // OSAH's visibility split (authors' rule): no unsplitting into a hidden child
  bool valid() const { return kind != Kind::None; }
};

// A split search can look for a second best split beside the plain one, under
// probabilities mixed with the visible fraction by `weight` (OSAH's visibility
// split, the authors' rule), from the same bins in the same pass.
struct VisibilitySearch {
  float weight = 0;
  Split* best = nullptr;  // nullptr: no second search
};

// Maps a reference's centroid to one of `bins` bins along an axis.
struct CentroidBinning {
  vec3 origin{0.0f};
  vec3 scale{0.0f};  // 0 on axes without extent
  uint32_t bins = 0;
  CentroidBinning(const Aabb& centroids, uint32_t bin_count) : origin(centroids.lo), bins(bin_count) {
    for (int a = 0; a < 3; ++a) {
      const float extent = centroids.hi[a] - centroids.lo[a];
      // (1 - 1e-6) keeps the largest centroid inside the last bin.
      const float s = extent > 0 ? float(bins) * (1.0f - 1e-6f) / extent : 0.0f;
      scale[a] = std::isfinite(s) ? s : 0.0f;
    }
#if defined(RTSIM_SAH_SSE2)
    origin_lanes = _mm_setr_ps(origin.x, origin.y, origin.z, 0.0f);
    scale_lanes = _mm_setr_ps(scale.x, scale.y, scale.z, 0.0f);
    last_lanes = _mm_set1_ps(float(bins - 1));
#endif
  }
  bool usable(int axis) const { return scale[axis] > 0; }
  uint32_t index(const Ref& r, int axis) const {
    const float f = (r.centroid2(axis) - origin[axis]) * scale[axis];
    if (!(f > 0.0f)) return 0;
    if (f >= float(bins - 1)) return bins - 1;
    return uint32_t(f);
  }
  // index() on the three axes at once (out[3] is not a bin), with the same float
  // operations: binning's hot loop.
  void indices(const Ref& r, uint32_t out[4]) const {
#if defined(RTSIM_SAH_SSE2)
    const __m128 f = _mm_mul_ps(
        _mm_sub_ps(_mm_add_ps(_mm_loadu_ps(&r.lo.x), _mm_loadu_ps(&r.hi.x)), origin_lanes),
        scale_lanes);
    // 0 unless f > 0 (NaN too), bins - 1 from there on, else f truncated.
    const __m128i i = _mm_and_si128(_mm_cvttps_epi32(_mm_min_ps(f, last_lanes)),
                                    _mm_castps_si128(_mm_cmpgt_ps(f, _mm_setzero_ps())));
    _mm_store_si128(reinterpret_cast<__m128i*>(out), i);
#else
    for (int a = 0; a < 3; ++a) out[a] = index(r, a);
#endif
  }
#if defined(RTSIM_SAH_SSE2)
  __m128 origin_lanes, scale_lanes, last_lanes;
#endif
};

// Boxes summed in SSE lanes, for the builder's hottest loops (binning, node info,
// the sweeps): a Ref's two halves are its lo and hi, with the tag and the weight
// in the fourth lane, which is never read. Bit-identical to Aabb: min(p, lo) and
// max(p, hi) are glm::min(lo, p) and glm::max(hi, p) lane by lane, NaN and signed
// zeros alike.
struct BoxLanes {
#if defined(RTSIM_SAH_SSE2)
  __m128 lo = _mm_set1_ps(kInf), hi = _mm_set1_ps(-kInf);
  void extend(__m128 l, __m128 h) {
    lo = _mm_min_ps(l, lo);
    hi = _mm_max_ps(h, hi);
  }
  void extend(const BoxLanes& b) { extend(b.lo, b.hi); }
  void extend_box(const Ref& r) { extend(_mm_loadu_ps(&r.lo.x), _mm_loadu_ps(&r.hi.x)); }
  void extend_centroid(const Ref& r) {
    const __m128 c = _mm_add_ps(_mm_loadu_ps(&r.lo.x), _mm_loadu_ps(&r.hi.x));
    extend(c, c);
  }
  // Aabb::area() with the same float operations.
  float area() const {
    if (_mm_movemask_ps(_mm_cmpgt_ps(lo, hi)) & 7) return 0.0f;  // empty
    const __m128 d = _mm_sub_ps(hi, lo);
    const __m128 p = _mm_mul_ps(d, _mm_shuffle_ps(d, d, _MM_SHUFFLE(3, 0, 2, 1)));  // xy, yz, zx
    const float xy = _mm_cvtss_f32(p);
    const float yz = _mm_cvtss_f32(_mm_shuffle_ps(p, p, _MM_SHUFFLE(1, 1, 1, 1)));
    const float zx = _mm_cvtss_f32(_mm_shuffle_ps(p, p, _MM_SHUFFLE(2, 2, 2, 2)));
    return 2.0f * (xy + yz + zx);
  }
  bool empty() const { return (_mm_movemask_ps(_mm_cmpgt_ps(lo, hi)) & 7) != 0; }  // Aabb::empty
  Aabb box() const {
    alignas(16) float l[4], h[4];
    _mm_store_ps(l, lo);
    _mm_store_ps(h, hi);
    return Aabb{vec3(l[0], l[1], l[2]), vec3(h[0], h[1], h[2])};
  }
#else
  Aabb bounds;
  void extend(const BoxLanes& b) { bounds.extend(b.bounds); }
  void extend_box(const Ref& r) { bounds.extend(r.box()); }
  void extend_centroid(const Ref& r) { bounds.extend(r.lo + r.hi); }
  float area() const { return bounds.area(); }
  bool empty() const { return bounds.empty(); }
  Aabb box() const { return bounds; }
#endif
  static BoxLanes of(const Ref& r) {
    BoxLanes b;
    b.extend_box(r);
    return b;
  }
};

// A reference's triangle cut at axis-aligned planes (SBVH reference splitting, Stich
// et al. 2009: the real triangle is clipped, not its box). The vertices are loaded
// once for all the planes one reference is cut at: spatial binning cuts each
// reference at every bin plane it spans, and that was half of an sbvh build.
class TriangleCut {
 public:
  TriangleCut(const Scene& scene, uint32_t tri) {
    for (int i = 0; i < 3; ++i) {
      v_[i] = scene.vertex(tri, i);
#if defined(RTSIM_SAH_SSE2)
      lanes_[i] = _mm_setr_ps(v_[i].x, v_[i].y, v_[i].z, 0.0f);
#endif
    }
  }
  // The boxes of the parts on each side of the plane, each within `within` and on
  // its own side: clip_triangle's boxes. In lanes, each operation is its glm/std
  // min, max and clamp, lane for lane (see BoxLanes), so the boxes are bit for bit
  // the same.
  void split(const BoxLanes& within, int axis, float position, BoxLanes* left, BoxLanes* right) const;

 private:
  vec3 v_[3];
#if defined(RTSIM_SAH_SSE2)
  __m128 lanes_[3];
#endif
};

#if defined(RTSIM_SAH_SSE2)
inline void TriangleCut::split(const BoxLanes& within, int axis, float position, BoxLanes* left,
                        BoxLanes* right) const {
  alignas(16) static const uint32_t kAxisLane[3][4] = {{~0u, 0, 0, 0}, {0, ~0u, 0, 0}, {0, 0, ~0u, 0}};
  const __m128 on_axis = _mm_load_ps(reinterpret_cast<const float*>(kAxisLane[axis]));
  const __m128 pos = _mm_set1_ps(position);
  // `position` in the axis lane, `other` in the rest.
  auto at_axis = [&](__m128 other) { return _mm_or_ps(_mm_and_ps(on_axis, pos), _mm_andnot_ps(on_axis, other)); };
  BoxLanes l, r;
  for (int e = 0; e < 3; ++e) {
    const int f = e == 2 ? 0 : e + 1;
    const float a = v_[e][axis], b = v_[f][axis];
    const __m128 va = lanes_[e], vb = lanes_[f];
    if (a <= position) l.extend(va, va);
    if (a >= position) r.extend(va, va);
    if ((a < position && position < b) || (b < position && position < a)) {
      const float t = (position - a) / (b - a);
      __m128 p = _mm_add_ps(va, _mm_mul_ps(_mm_set1_ps(t), _mm_sub_ps(vb, va)));  // a + t * (b - a)
      // glm::clamp(p, glm::min(a, b), glm::max(a, b))
      p = _mm_min_ps(_mm_max_ps(vb, va), _mm_max_ps(_mm_min_ps(vb, va), p));
      p = at_axis(p);
      l.extend(p, p);
      r.extend(p, p);
    }
  }
  // Aabb::intersection with `within`, then each side stops at the plane.
  l.lo = _mm_max_ps(within.lo, l.lo);
  l.hi = _mm_min_ps(within.hi, l.hi);
  r.lo = _mm_max_ps(within.lo, r.lo);
  r.hi = _mm_min_ps(within.hi, r.hi);
  l.hi = _mm_min_ps(at_axis(_mm_set1_ps(kInf)), l.hi);  // std::min(hi, position) on the axis
  r.lo = _mm_max_ps(at_axis(_mm_set1_ps(-kInf)), r.lo);  // std::max(lo, position)
  *left = l;
  *right = r;
}
#else
inline void TriangleCut::split(const BoxLanes& within, int axis, float position, BoxLanes* left,
                               BoxLanes* right) const {
  clip_triangle(v_, axis, position, within.bounds, &left->bounds, &right->bounds);
}
#endif

// A bin (and a running sum of bins or references): box, weight, counts.
struct Bin {
  BoxLanes bounds;
  float weight = 0;
  uint32_t count = 0;
  uint32_t visible = 0;
  void add(const Ref& r) {
    bounds.extend_box(r);
    weight += r.weight;
    count += 1;
    visible += r.visible();
  }
  void add(const Bin& b) {
    bounds.extend(b.bounds);
    weight += b.weight;
    count += b.count;
    visible += b.visible;
  }
  float area() const { return bounds.area(); }
  Aabb box() const { return bounds.box(); }
};

// NodeInfo's accumulator: a Bin plus the centroid bounds (lo + hi, twice the
// centre, as Ref::centroid2).
struct NodeInfoLanes {
  Bin refs;
  BoxLanes centroids;
  void add(const Ref& r) {
    refs.add(r);
    centroids.extend_centroid(r);
  }
  void add(const NodeInfoLanes& o) {
    refs.add(o.refs);
    centroids.extend(o.centroids);
  }
  NodeInfo info() const {
    NodeInfo out;
    out.box = refs.box();
    out.centroids = centroids.box();
    out.weight = refs.weight, out.visible = refs.visible, out.count = refs.count;
    return out;
  }
};

// Maps a coordinate to a spatial bin of the node box along an axis.
struct SpatialBinning {
  float origin = 0, extent = 0, scale = 0;
  uint32_t bins = 0;
  SpatialBinning(float lo, float hi, uint32_t bin_count) : origin(lo), extent(hi - lo), bins(bin_count) {
    const float s = extent > 0 ? float(bins) * (1.0f - 1e-6f) / extent : 0.0f;
    scale = std::isfinite(s) ? s : 0.0f;
  }
  uint32_t index(float x) const {
    const float f = (x - origin) * scale;
    if (!(f > 0.0f)) return 0;
    if (f >= float(bins - 1)) return bins - 1;
    return uint32_t(f);
  }
  float plane(uint32_t after_bin) const { return origin + extent * float(after_bin + 1) / float(bins); }
};

// The sweep's order along an axis: slots of the node's range sorted by RefLess,
// with the centroid precomputed as the key (the geometric order only breaks ties).
struct SweepKey {
  float key;
  uint32_t slot;
};

constexpr uint32_t kSmallSweep = 64;

// A node's references sorted along each axis (slots relative to the node's first).
// A swept node passes its children their parts of its three orders, still sorted, so
// that a small subtree sorts once instead of at every level (the order is a strict
// total order, so a sorted subset is the subset sorted).
struct SweepOrders {
  SweepKey* keys[3] = {nullptr, nullptr, nullptr};
  bool sorted[3] = {false, false, false};
};

// RDH: how many of a node's sample rays meet a candidate's two child boxes.
struct RayCounts {
  uint32_t left = 0, right = 0, node = 0;  // node = 0: no rays, the surface-area rule
};

// For m candidates whose left boxes grow with the index (left[i] within
// left[i + 1]) and whose right boxes shrink (right[i + 1] within right[i]) - true
// of binned and swept object splits, whose children are unions of a prefix and a
// suffix - a ray meeting left[i] meets every later left box, and the slab test is
// monotone in the box in floating point too. So the first left box and the last
// right box a ray meets are found by bisection, and prefix/suffix sums give the
// exact counts of every candidate: O(n log m) slab tests instead of O(n m).
void count_candidate_rays(const RaySamples& rays, const std::vector<uint32_t>& ids,
                          const Aabb* left, const Aabb* right, uint32_t m, uint32_t* n_left,
                          uint32_t* n_right) {
  std::fill(n_left, n_left + m, 0u);
  std::fill(n_right, n_right + m, 0u);
  if (m == 0) return;
  for (const uint32_t ray : ids) {
    if (rays.hits(ray, left[m - 1])) {
      uint32_t lo = 0, hi = m - 1;  // smallest i meeting left[i]
      while (lo < hi) {
        const uint32_t mid = (lo + hi) / 2;
        if (rays.hits(ray, left[mid])) hi = mid;
        else lo = mid + 1;
      }
      n_left[lo] += 1;
    }
    if (rays.hits(ray, right[0])) {
      uint32_t lo = 0, hi = m - 1;  // largest i meeting right[i]
      while (lo < hi) {
        const uint32_t mid = (lo + hi + 1) / 2;
        if (rays.hits(ray, right[mid])) lo = mid;
        else hi = mid - 1;
      }
      n_right[lo] += 1;
    }
  }
  for (uint32_t i = 1; i < m; ++i) n_left[i] += n_left[i - 1];
  for (uint32_t i = m - 1; i > 0; --i) n_right[i - 1] += n_right[i];
}

// The running sums of one axis's candidate splits: for items 0..n-1 in order (bins,
// or references sorted by centroid), candidate i puts items 0..i left and i+1..n-1
// right. Sized for the small nodes on the stack, for larger ones on the heap.
class CandidateScratch {
 public:
  struct RightSums {
    float area, weight;
    uint32_t count, visible;
  };
  CandidateScratch(uint32_t items, bool with_rays) {
    if (items > kSmallItems) {
      heap_.resize(items);
      right = heap_.data();
    }
    if (with_rays) {  // RDH: each candidate's child boxes and their ray counts
      left_boxes.resize(items);
      right_boxes.resize(items);
      rays_left.resize(items);
      rays_right.resize(items);
    }
  }
  RightSums* right = small_;
  std::vector<Aabb> left_boxes, right_boxes;
  std::vector<uint32_t> rays_left, rays_right;

 private:
  static constexpr uint32_t kSmallItems = std::max(kMaxBins, kSmallSweep);
  RightSums small_[kSmallItems];
  std::vector<RightSums> heap_;
};

// A partitioned node's children: their reference counts, and the slots the left
// child may grow into (SBVH's reference budget; the right child has the rest).
struct ChildRanges {
  uint32_t left_count = 0, right_count = 0, left_capacity = 0;
};

struct TempNode {
  Aabb box;
  uint32_t left = ~0u, right = ~0u;  // ~0u: leaf
  uint32_t begin = 0, count = 0;
  uint32_t visible = 0;  // visible references below (OSAH's child order)
};

class Builder {
 public:
  Builder(const Scene& scene, const CoreConfig& config) : scene_(scene), config_(config) {}

  Bvh run(CoreStats* stats);

 private:
  Bvh run_once(bool spatial_at_root, CoreStats* stats);
  uint32_t build(uint32_t begin, uint32_t count, uint32_t capacity, uint32_t depth,
                 const std::vector<uint32_t>* parent_rays, const SweepOrders* presorted = nullptr);
  NodeInfo node_info(uint32_t begin, uint32_t count) const;
  float split_cost(float area_left, float weight_left, uint32_t visible_left, float area_right,
                   float weight_right, uint32_t visible_right, float node_area,
                   const NodeInfo& info, float mix, RayCounts rays = RayCounts{}) const;
  template <class AddItem>
  void evaluate_candidates(Split::Kind kind, int axis, uint32_t items, AddItem add_item, const NodeInfo& info,
                           const std::vector<uint32_t>& rays, CandidateScratch& scratch, Split& best,
                           VisibilitySearch search) const;
  Split find_object_split(uint32_t begin, uint32_t count, const NodeInfo& info,
                          const std::vector<uint32_t>& rays, VisibilitySearch search = {}) const;
  Split find_sweep_split(uint32_t begin, uint32_t count, const NodeInfo& info, SweepOrders& orders,
                         const std::vector<uint32_t>& rays, VisibilitySearch search = {}) const;
  Split find_spatial_split(uint32_t begin, uint32_t count, const NodeInfo& info,
                           const std::vector<uint32_t>& rays, VisibilitySearch search = {}) const;
  Split choose_split(uint32_t begin, uint32_t count, uint32_t capacity, uint32_t depth, const NodeInfo& info,
                     SweepOrders& orders, const std::vector<uint32_t>& rays, Split* object_fallback) const;
  Split find_object_or_sweep(uint32_t begin, uint32_t count, const NodeInfo& info, SweepOrders& orders,
                             const std::vector<uint32_t>& rays, VisibilitySearch search = {}) const;
  Split with_spatial_split(const Split& object, uint32_t begin, uint32_t count, uint32_t capacity,
                           uint32_t depth, const NodeInfo& info, const std::vector<uint32_t>& rays) const;
  bool sweeps(uint32_t count) const;
  static bool fits(const Split& s, uint32_t capacity) {
    return uint64_t(s.left_count) + s.right_count <= capacity;
  }
  uint32_t partition_object(const Split& split, uint32_t begin, uint32_t count,
                            const NodeInfo& info, const SweepKey* sweep_order);
  bool partition_spatial(const Split& split, uint32_t begin, uint32_t count, uint32_t capacity,
                         const NodeInfo& info, uint32_t* left_count, uint32_t* right_count,
                         uint32_t* left_capacity);
  uint32_t partition_median(uint32_t begin, uint32_t count, const NodeInfo& info);
  std::vector<uint32_t> rays_meeting(const Aabb& box, const std::vector<uint32_t>* parent_rays);
  ChildRanges partition_node(Split& best, const Split& object_fallback, uint32_t begin, uint32_t count,
                             uint32_t capacity, uint32_t depth, const NodeInfo& info, const SweepOrders& orders,
                             bool* by_split);
  static void split_child_orders(const SweepOrders& orders, int axis, uint32_t count, uint32_t left_count,
                                 SweepKey (&child_keys)[2][3][kSmallSweep], SweepOrders (&child_orders)[2]);
  static double need(const Ref* refs, uint32_t count);
  static uint32_t left_share(uint32_t spare, const Ref* left, uint32_t nl, const Ref* right,
                             uint32_t nr);
  uint32_t spatial_bins() const {
    return std::min<uint32_t>(config_.bins == 0 ? 32 : config_.bins, kMaxBins);
  }
  bool depth_allows(uint32_t depth, uint64_t left, uint64_t right) const {
    return depth + 1 + levels_needed(left, config_.max_leaf_size) <= config_.max_depth &&
           depth + 1 + levels_needed(right, config_.max_leaf_size) <= config_.max_depth;
  }

  const Scene& scene_;
  const CoreConfig& config_;
  std::vector<Ref> refs_;
  tbb::concurrent_vector<TempNode> nodes_;
  float root_area_ = 0;
  bool spatial_at_root_ = true;  // false: the root takes the best object split
  bool root_split_spatial_ = false;
  std::atomic<uint64_t> forced_splits_{0}, median_splits_{0}, visibility_splits_{0};
  std::atomic<uint64_t> ray_node_pairs_{0};
};

NodeInfo Builder::node_info(uint32_t begin, uint32_t count) const {
  if (count < 2 * kChunk) {
    NodeInfoLanes info;
    for (uint32_t i = begin; i < begin + count; ++i) info.add(refs_[i]);
    return info.info();
  }
  // Fixed chunks reduced in chunk order: the float weight sum does not depend on
  // the thread count.
  const uint32_t chunks = (count + kChunk - 1) / kChunk;
  std::vector<NodeInfoLanes> partial(chunks);
  tbb::parallel_for(uint32_t(0), chunks, [&](uint32_t c) {
    const uint32_t lo = begin + c * kChunk, hi = std::min(begin + count, lo + kChunk);
    for (uint32_t i = lo; i < hi; ++i) partial[c].add(refs_[i]);
  });
  NodeInfoLanes info;
  for (const NodeInfoLanes& p : partial) info.add(p);
  return info.info();
}

inline float Builder::split_cost(float area_left, float weight_left, uint32_t visible_left,
                                 float area_right, float weight_right, uint32_t visible_right,
                                 float node_area, const NodeInfo& info, float mix, RayCounts rays) const {
  float p_left = 1.0f, p_right = 1.0f;
  // A node box without area (all vertices on a line or a point) gives no
  // probability information: both children count as certainly visited.
  if (node_area > 0) {
    p_left = area_left / node_area;
    p_right = area_right / node_area;
  }
  // RDH: the node's sample rays plus k pseudo-rays spread by surface area. Written
  // as (a + n_i / k) / (1 + n / k) so that n = 0, or k so large that n / k
  // vanishes, gives exactly the surface-area ratio a (hence the SAH tree).
  if (rays.node > 0) {
    const float k = config_.rdh_prior;
    const float denominator = 1.0f + float(rays.node) / k;
    p_left = (p_left + float(rays.left) / k) / denominator;
    p_right = (p_right + float(rays.right) / k) / denominator;
  }
  // OSAH's visibility split: P_i = w * V_i / V + (1 - w) * P_i (mix = w; 0 for every
  // plain candidate).
  if (mix > 0 && info.visible > 0) {
    const float v = float(info.visible);
    p_left = mix * float(visible_left) / v + (1.0f - mix) * p_left;
    p_right = mix * float(visible_right) / v + (1.0f - mix) * p_right;
  }
  return 2.0f * config_.t1 + config_.t2 * (p_left * weight_left + p_right * weight_right);
}

// The one split evaluation of the binned and the exact (swept) object splits: the
// items of one axis in order, add_item(sum, i) adding item i to a running sum.
// Suffix sums first, then (RDH) every candidate's ray counts, then one prefix pass
// pricing each candidate with both children non-empty, plainly and, when asked,
// under OSAH's visibility-mixed probabilities.
template <class AddItem>
void Builder::evaluate_candidates(Split::Kind kind, int axis, uint32_t items, AddItem add_item,
                                  const NodeInfo& info, const std::vector<uint32_t>& rays,
                                  CandidateScratch& scratch, Split& best, VisibilitySearch search) const {
  const float node_area = info.box.area();
  const bool with_rays = !rays.empty();
  CandidateScratch::RightSums* right = scratch.right;
  Bin suffix;
  for (uint32_t i = items - 1; i > 0; --i) {
    add_item(suffix, i);
    right[i] = {suffix.area(), suffix.weight, suffix.count, suffix.visible};
    if (with_rays) scratch.right_boxes[i - 1] = suffix.box();
  }
  if (with_rays) {
    Bin prefix;
    for (uint32_t i = 0; i + 1 < items; ++i) {
      add_item(prefix, i);
      scratch.left_boxes[i] = prefix.box();
    }
    count_candidate_rays(*config_.rays, rays, scratch.left_boxes.data(), scratch.right_boxes.data(), items - 1,
                         scratch.rays_left.data(), scratch.rays_right.data());
  }
  Bin left;
  for (uint32_t i = 0; i + 1 < items; ++i) {
    add_item(left, i);
    const CandidateScratch::RightSums& r = right[i + 1];
    if (left.count == 0 || r.count == 0) continue;  // empty bins at either end
    const RayCounts counts = with_rays ? RayCounts{scratch.rays_left[i], scratch.rays_right[i], uint32_t(rays.size())}
                                       : RayCounts{};
    auto take = [&](Split& s, float cost) {
      s.kind = kind;
      s.axis = axis;
      s.bin = i;
      s.cost = cost;
      s.left_count = left.count;
      s.right_count = r.count;
      s.left_visible = left.visible;
      s.right_visible = r.visible;
      s.left_box = left.box();
    };
    const float area = left.area();
    const float cost =
        split_cost(area, left.weight, left.visible, r.area, r.weight, r.visible, node_area, info, 0.0f, counts);
    if (cost < best.cost) take(best, cost);
    if (search.best) {
      const float mixed = split_cost(area, left.weight, left.visible, r.area, r.weight, r.visible, node_area, info,
                                     search.weight, counts);
      if (mixed < search.best->cost) take(*search.best, mixed);
    }
  }
}

Split Builder::find_object_split(uint32_t begin, uint32_t count, const NodeInfo& info,
                                 const std::vector<uint32_t>& rays, VisibilitySearch search) const {
  const uint32_t bins = config_.bins;
  const CentroidBinning binning(info.centroids, bins);
  Split best;
  if (!binning.usable(0) && !binning.usable(1) && !binning.usable(2)) return best;

  // Only the 3 x bins entries in use are initialised (the store is sized for the
  // maximum bin count; initialising all of it per node dominated the build time).
  alignas(64) unsigned char bin_bytes[3 * kMaxBins * sizeof(Bin)];
  Bin* binned = reinterpret_cast<Bin*>(bin_bytes);
  for (uint32_t k = 0; k < 3 * bins; ++k) new (binned + k) Bin();
  const bool usable[3] = {binning.usable(0), binning.usable(1), binning.usable(2)};
  auto bin_range = [&](Bin* out, uint32_t lo, uint32_t hi) {
    alignas(16) uint32_t index[4];
    for (uint32_t i = lo; i < hi; ++i) {
      const Ref& r = refs_[i];
      binning.indices(r, index);
      for (int a = 0; a < 3; ++a)
        if (usable[a]) out[a * bins + index[a]].add(r);
    }
  };
  if (count < 2 * kChunk) {
    bin_range(binned, begin, begin + count);
  } else {
    const uint32_t chunks = (count + kChunk - 1) / kChunk;
    std::vector<Bin> partial(size_t(chunks) * 3 * bins);
    tbb::parallel_for(uint32_t(0), chunks, [&](uint32_t c) {
      const uint32_t lo = begin + c * kChunk, hi = std::min(begin + count, lo + kChunk);
      bin_range(&partial[size_t(c) * 3 * bins], lo, hi);
    });
    for (uint32_t c = 0; c < chunks; ++c)
      for (uint32_t k = 0; k < 3 * bins; ++k) binned[k].add(partial[size_t(c) * 3 * bins + k]);
  }

  CandidateScratch scratch(bins, !rays.empty());
  for (int a = 0; a < 3; ++a) {
    if (!binning.usable(a)) continue;
    const Bin* axis_bins = binned + a * bins;
    evaluate_candidates(Split::Kind::Object, a, bins, [&](Bin& sum, uint32_t i) { sum.add(axis_bins[i]); },
                        info, rays, scratch, best, search);
  }
  // The right box is needed by the SBVH overlap test only; recompute it here.
  for (Split* s : {&best, search.best}) {
    if (!s || !s->valid()) continue;
    Bin right;
    for (uint32_t i = s->bin + 1; i < bins; ++i) right.add(binned[s->axis * bins + i]);
    s->right_box = right.box();
  }
  return best;
}

void sweep_order(const Scene& scene, const Ref* refs, uint32_t count, int axis, SweepKey* keys) {
  for (uint32_t i = 0; i < count; ++i) keys[i] = SweepKey{refs[i].centroid2(axis), i};
  auto less = [&](const SweepKey& a, const SweepKey& b) {
    if (a.key != b.key) return a.key < b.key;
    return ref_geometric_less(scene, refs[a.slot], refs[b.slot]);
  };
  if (count > kSmallSweep) {
    std::sort(keys, keys + count, less);
    return;
  }
  // Insertion sort: the nodes swept here are small.
  for (uint32_t i = 1; i < count; ++i) {
    const SweepKey k = keys[i];
    uint32_t j = i;
    for (; j > 0 && less(k, keys[j - 1]); --j) keys[j] = keys[j - 1];
    keys[j] = k;
  }
}

// orders (count entries per axis) are sorted here where they are not yet; the best
// split's axis order is what partition_object then applies without sorting again.
Split Builder::find_sweep_split(uint32_t begin, uint32_t count, const NodeInfo& info, SweepOrders& orders,
                                const std::vector<uint32_t>& rays, VisibilitySearch search) const {
  Split best;
  if (count < 2) return best;
  const Ref* refs = refs_.data() + begin;
  CandidateScratch scratch(count, !rays.empty());
  for (int a = 0; a < 3; ++a) {
    if (!(info.centroids.hi[a] > info.centroids.lo[a])) continue;
    SweepKey* keys = orders.keys[a];
    if (!orders.sorted[a]) sweep_order(scene_, refs, count, a, keys);
    orders.sorted[a] = true;
    evaluate_candidates(Split::Kind::Sweep, a, count, [&](Bin& sum, uint32_t i) { sum.add(refs[keys[i].slot]); },
                        info, rays, scratch, best, search);
  }
  if (config_.spatial_splits) {
    // The right box is needed by the SBVH overlap test only.
    for (Split* s : {&best, search.best}) {
      if (!s || !s->valid()) continue;
      Aabb right;
      for (uint32_t i = s->bin + 1; i < count; ++i) right.extend(refs[orders.keys[s->axis][i].slot].box());
      s->right_box = right;
    }
  }
  return best;
}

Split Builder::find_spatial_split(uint32_t begin, uint32_t count, const NodeInfo& info,
                                  const std::vector<uint32_t>& rays, VisibilitySearch search) const {
  const uint32_t bins = spatial_bins();
  const float node_area = info.box.area();
  Split best;
  struct SpatialBin {
    BoxLanes box;
    float enter_weight = 0, exit_weight = 0;
    uint32_t enter = 0, exit = 0, enter_visible = 0, exit_visible = 0;
  };
  std::vector<SpatialBin> b(bins);
  std::vector<float> right_area(bins), right_weight(bins);
  std::vector<uint32_t> right_count(bins), right_visible(bins);
  // RDH: the candidates' child boxes are unions of a prefix and a suffix of the
  // bins too (nested), so the rays are counted the same way as for object splits.
  const bool with_rays = !rays.empty();
  std::vector<Aabb> left_boxes(with_rays ? bins : 0), right_boxes(with_rays ? bins : 0);
  std::vector<uint32_t> rays_left(with_rays ? bins : 0), rays_right(with_rays ? bins : 0);
  for (int a = 0; a < 3; ++a) {
    const SpatialBinning binning(info.box.lo[a], info.box.hi[a], bins);
    if (!(binning.scale > 0)) continue;
    std::fill(b.begin(), b.end(), SpatialBin{});
    for (uint32_t i = begin; i < begin + count; ++i) {
      const Ref& r = refs_[i];
      const uint32_t b0 = binning.index(r.lo[a]), b1 = binning.index(r.hi[a]);
      b[b0].enter += 1;
      b[b0].enter_weight += r.weight;
      b[b0].enter_visible += r.visible();
      b[b1].exit += 1;
      b[b1].exit_weight += r.weight;
      b[b1].exit_visible += r.visible();
      if (b0 == b1 || r.splits() >= config_.split_limit) {
        // Not split: the whole box counts in every bin it spans (conservative).
        for (uint32_t k = b0; k <= b1; ++k) b[k].box.extend_box(r);
        continue;
      }
      const TriangleCut cut(scene_, r.prim());
      BoxLanes rest = BoxLanes::of(r), left, right;
      for (uint32_t k = b0; k < b1; ++k) {
        cut.split(rest, a, binning.plane(k), &left, &right);
        if (!left.empty()) b[k].box.extend(left);
        if (right.empty()) break;
        rest = right;
        if (k + 1 == b1) b[b1].box.extend(right);
      }
    }
    SpatialBin acc;
    for (uint32_t i = bins - 1; i > 0; --i) {
      acc.box.extend(b[i].box);
      acc.exit += b[i].exit;
      acc.exit_weight += b[i].exit_weight;
      acc.exit_visible += b[i].exit_visible;
      right_area[i] = acc.box.area();
      right_weight[i] = acc.exit_weight;
      right_count[i] = acc.exit;
      right_visible[i] = acc.exit_visible;
      if (with_rays) right_boxes[i - 1] = acc.box.box();
    }
    if (with_rays) {
      BoxLanes grow;
      for (uint32_t i = 0; i + 1 < bins; ++i) {
        grow.extend(b[i].box);
        left_boxes[i] = grow.box();
      }
      count_candidate_rays(*config_.rays, rays, left_boxes.data(), right_boxes.data(), bins - 1,
                           rays_left.data(), rays_right.data());
    }
    SpatialBin left;
    for (uint32_t i = 0; i + 1 < bins; ++i) {
      left.box.extend(b[i].box);
      left.enter += b[i].enter;
      left.enter_weight += b[i].enter_weight;
      left.enter_visible += b[i].enter_visible;
      if (left.enter == 0 || right_count[i + 1] == 0) continue;
      const RayCounts counts =
          with_rays ? RayCounts{rays_left[i], rays_right[i], uint32_t(rays.size())} : RayCounts{};
      auto take = [&](Split& s, float cost) {
        s.kind = Split::Kind::Spatial;
        s.axis = a;
        s.bin = i;
        s.position = binning.plane(i);
        s.cost = cost;
        s.left_count = left.enter;
        s.right_count = right_count[i + 1];
        s.left_visible = left.enter_visible;
        s.right_visible = right_visible[i + 1];
        s.left_box = left.box.box();
        s.left_weight = left.enter_weight;
        s.right_weight = right_weight[i + 1];
      };
      const float cost = split_cost(left.box.area(), left.enter_weight, left.enter_visible, right_area[i + 1],
                                    right_weight[i + 1], right_visible[i + 1], node_area, info,
                                    0.0f, counts);
      if (cost < best.cost) take(best, cost);
      if (search.best) {
        const float mixed = split_cost(left.box.area(), left.enter_weight, left.enter_visible,
                                       right_area[i + 1], right_weight[i + 1], right_visible[i + 1],
                                       node_area, info, search.weight, counts);
        if (mixed < search.best->cost) take(*search.best, mixed);
      }
    }
    // This axis's bins are gone after the loop: the right boxes of the splits on it now.
    for (Split* s : {&best, search.best}) {
      if (!s || s->kind != Split::Kind::Spatial || s->axis != a) continue;
      BoxLanes right;
      for (uint32_t i = s->bin + 1; i < bins; ++i) right.extend(b[i].box);
      s->right_box = right.box();
    }
  }
  return best;
}

uint32_t Builder::partition_object(const Split& split, uint32_t begin, uint32_t count,
                                   const NodeInfo& info, const SweepKey* sweep_order) {
  Ref* first = refs_.data() + begin;
  Ref* last = first + count;
  Ref* middle;
  if (split.kind == Split::Kind::Sweep) {
    Ref small_refs[kSmallSweep];
    std::vector<Ref> big_refs(count > kSmallSweep ? count : 0);
    Ref* ordered = count > kSmallSweep ? big_refs.data() : small_refs;
    for (uint32_t i = 0; i < count; ++i) ordered[i] = first[sweep_order[i].slot];
    std::copy(ordered, ordered + count, first);
    middle = first + split.bin + 1;
  } else {
    const CentroidBinning binning(info.centroids, config_.bins);
    middle = std::partition(first, last, [&](const Ref& r) {
      return binning.index(r, split.axis) <= split.bin;
    });
  }
  return uint32_t(middle - first);
}

// Object median along the widest centroid axis (with all centroids equal, the
// median of the geometric order).
uint32_t Builder::partition_median(uint32_t begin, uint32_t count, const NodeInfo& info) {
  const vec3 extent = info.centroids.hi - info.centroids.lo;
  int axis = 0;
  if (extent.y > extent[axis]) axis = 1;
  if (extent.z > extent[axis]) axis = 2;
  const uint32_t half = count / 2;
  Ref* first = refs_.data() + begin;
  std::nth_element(first, first + half, first + count, RefLess{&scene_, axis});
  return half;
}

// A subtree's need for spare references (SBVH budget): the summed surface area of
// its reference boxes. A split saves cost in proportion to the area it cuts off,
// so large triangles are where splits pay; sharing the spare by count left most
// of it with finely tessellated subtrees that never split (cg57).
double Builder::need(const Ref* refs, uint32_t count) {
  double sum = 0;
  for (uint32_t i = 0; i < count; ++i) sum += refs[i].box().area();
  return sum;
}

// The left child's part of `spare`, in proportion to the two children's needs (a
// serial sum in reference order: the same for any thread count).
uint32_t Builder::left_share(uint32_t spare, const Ref* left, uint32_t nl, const Ref* right,
                             uint32_t nr) {
  if (spare == 0) return 0;
  const double l = need(left, nl), r = need(right, nr);
  if (!(l + r > 0)) return uint32_t(uint64_t(spare) * nl / (nl + nr));
  return std::min<uint32_t>(spare, uint32_t(double(spare) * (l / (l + r))));
}

bool Builder::partition_spatial(const Split& split, uint32_t begin, uint32_t count,
                                uint32_t capacity, const NodeInfo& info, uint32_t* left_count,
                                uint32_t* right_count, uint32_t* left_capacity) {
  const uint32_t bins = spatial_bins();
  const int a = split.axis;
  const SpatialBinning binning(info.box.lo[a], info.box.hi[a], bins);
  std::vector<Ref> left, right;
  left.reserve(split.left_count);
  right.reserve(split.right_count);
  Aabb left_box = split.left_box, right_box = split.right_box;
  float left_weight = split.left_weight, right_weight = split.right_weight;
  std::vector<Ref> straddling;
  for (uint32_t i = begin; i < begin + count; ++i) {
    const Ref& r = refs_[i];
    const uint32_t b0 = binning.index(r.lo[a]), b1 = binning.index(r.hi[a]);
    if (b1 <= split.bin) left.push_back(r);
    else if (b0 > split.bin) right.push_back(r);
    else straddling.push_back(r);
  }
  // Unsplitting decides one reference at a time, each seeing the boxes the earlier
  // ones grew: take them in the geometric order, not the input's.
  std::sort(straddling.begin(), straddling.end(),
            [&](const Ref& x, const Ref& y) { return ref_geometric_less(scene_, x, y); });
  for (const Ref& r : straddling) {
    // Reference unsplitting (Stich et al. 2009): keep the reference whole on one
    // side when that is cheaper than duplicating it.
    Aabb left_with = left_box, right_with = right_box;
    left_with.extend(r.box());
    right_with.extend(r.box());
    const float cost_whole_left =
        left_with.area() * left_weight + right_box.area() * (right_weight - r.weight);
    const float cost_whole_right =
        left_box.area() * (left_weight - r.weight) + right_with.area() * right_weight;
    const float cost_split = left_box.area() * left_weight + right_box.area() * right_weight;
    const bool may_split = r.splits() < config_.split_limit;
    // OSAH's visibility split keeps its hidden child tight: a straddling reference
    // goes whole only into a child that holds visible references.
    const float whole_left = !split.visibility || split.left_visible > 0 ? cost_whole_left : kInf;
    const float whole_right = !split.visibility || split.right_visible > 0 ? cost_whole_right : kInf;
    if (may_split && cost_split <= whole_left && cost_split <= whole_right) {
      BoxLanes left_part, right_part;
      TriangleCut(scene_, r.prim()).split(BoxLanes::of(r), a, split.position, &left_part, &right_part);
      const Aabb lb = left_part.box(), rb = right_part.box();
      if (lb.empty()) {
        right.push_back(r);
      } else if (rb.empty()) {
        left.push_back(r);
      } else {
        Ref l = r, rr = r;
        const uint32_t tag = (r.tag & ~kSplitMask) | ((r.splits() + 1) << kSplitShift);
        l.lo = lb.lo, l.hi = lb.hi, l.tag = tag;
        rr.lo = rb.lo, rr.hi = rb.hi, rr.tag = tag;
        left.push_back(l);
        right.push_back(rr);
      }
    } else if (whole_left <= whole_right) {
      left.push_back(r);
      left_box = left_with;
      right_weight -= r.weight;
    } else {
      right.push_back(r);
      right_box = right_with;
      left_weight -= r.weight;
    }
  }
  // Never an empty child; never over the node's share of the reference budget.
  if (left.empty() || right.empty() || left.size() + right.size() > capacity) return false;
  const uint32_t nl = uint32_t(left.size()), nr = uint32_t(right.size());
  const uint32_t spare = capacity - nl - nr;
  const uint32_t cap_left = nl + left_share(spare, left.data(), nl, right.data(), nr);
  std::copy(left.begin(), left.end(), refs_.begin() + begin);
  std::copy(right.begin(), right.end(), refs_.begin() + begin + cap_left);
  *left_count = nl;
  *right_count = nr;
  *left_capacity = cap_left;
  return true;
}

// RDH: the parent's sample rays whose segment meets this node's box, in the
// parent's order (sequential: the same list for any thread count). The root
// filters all rays.
std::vector<uint32_t> Builder::rays_meeting(const Aabb& box, const std::vector<uint32_t>* parent_rays) {
  const RaySamples& samples = *config_.rays;
  std::vector<uint32_t> rays;
  if (parent_rays) {
    for (const uint32_t r : *parent_rays)
      if (samples.hits(r, box)) rays.push_back(r);
  } else {
    for (uint32_t r = 0; r < uint32_t(samples.size()); ++r)
      if (samples.hits(r, box)) rays.push_back(r);
  }
  ray_node_pairs_.fetch_add(rays.size());
  return rays;
}

// Applies the chosen split to refs_, or a fallback where it cannot be used: a
// spatial split whose children came out empty or over the budget takes the best
// object split instead (refs_ is untouched then), as the authors' OSAH does; with no
// usable split at all, the median. *by_split: false for the median.
ChildRanges Builder::partition_node(Split& best, const Split& object_fallback, uint32_t begin, uint32_t count,
                                    uint32_t capacity, uint32_t depth, const NodeInfo& info,
                                    const SweepOrders& orders, bool* by_split) {
  ChildRanges c;
  bool partitioned = false;
  auto partition_by_object = [&] {
    c.left_count = partition_object(best, begin, count, info, orders.keys[best.axis]);
    c.right_count = count - c.left_count;
    partitioned = c.left_count > 0 && c.right_count > 0;
  };
  if (best.valid() && depth_allows(depth, best.left_count, best.right_count)) {
    if (best.kind == Split::Kind::Spatial) {
      partitioned = partition_spatial(best, begin, count, capacity, info, &c.left_count, &c.right_count,
                                      &c.left_capacity);
      if (partitioned && depth == 0) root_split_spatial_ = true;
      if (partitioned && best.visibility) visibility_splits_.fetch_add(1);
      if (!partitioned && object_fallback.valid() &&
          depth_allows(depth, object_fallback.left_count, object_fallback.right_count)) {
        best = object_fallback;
        partition_by_object();
      }
    } else {
      partition_by_object();
      if (partitioned && best.visibility) visibility_splits_.fetch_add(1);
    }
  }
  if (!partitioned) {
    // No usable SAH split (all centroids in one bin, or the depth limit is near):
    // a balanced split keeps both the leaf-size and the depth limits.
    median_splits_.fetch_add(1);
    c.left_count = partition_median(begin, count, info);
    c.right_count = count - c.left_count;
  }
  if (c.left_capacity == 0) {
    // Share the node's spare references (SBVH budget) by the children's needs.
    const uint32_t spare = capacity - c.left_count - c.right_count;
    c.left_capacity = c.left_count + left_share(spare, refs_.data() + begin, c.left_count,
                                                refs_.data() + begin + c.left_count, c.right_count);
    if (c.left_capacity > c.left_count) {
      Ref* first = refs_.data() + begin;
      std::move_backward(first + c.left_count, first + count, first + c.left_capacity + c.right_count);
    }
  }
  *by_split = partitioned;
  return c;
}

// A small swept node hands its children their parts of its orders: slot i of the
// split axis's order is now slot i of the node, so each axis's order, read in turn,
// is split into the left and the right child's, still sorted.
void Builder::split_child_orders(const SweepOrders& orders, int axis, uint32_t count, uint32_t left_count,
                                 SweepKey (&child_keys)[2][3][kSmallSweep], SweepOrders (&child_orders)[2]) {
  uint8_t position[kSmallSweep];
  const SweepKey* by_split_axis = orders.keys[axis];
  for (uint32_t i = 0; i < count; ++i) position[by_split_axis[i].slot] = uint8_t(i);
  for (int a = 0; a < 3; ++a) {
    if (!orders.sorted[a]) continue;  // a flat axis: the children's are flat too
    uint32_t nl = 0, nr = 0;
    for (uint32_t i = 0; i < count; ++i) {
      const uint32_t p = position[orders.keys[a][i].slot];
      if (p < left_count) child_keys[0][a][nl++] = SweepKey{orders.keys[a][i].key, p};
      else child_keys[1][a][nr++] = SweepKey{orders.keys[a][i].key, p - left_count};
    }
    for (int c = 0; c < 2; ++c) child_orders[c].sorted[a] = true;
  }
  for (int c = 0; c < 2; ++c)
    for (int a = 0; a < 3; ++a) child_orders[c].keys[a] = child_keys[c][a];
}

// One node: its box, then leaf or split, partition, and the two children (in
// parallel for large nodes).
uint32_t Builder::build(uint32_t begin, uint32_t count, uint32_t capacity, uint32_t depth,
                        const std::vector<uint32_t>* parent_rays, const SweepOrders* presorted) {
  const NodeInfo info = node_info(begin, count);
  const uint32_t index = uint32_t(nodes_.emplace_back() - nodes_.begin());
  nodes_[index].box = info.box;
  nodes_[index].visible = info.visible;
  const std::vector<uint32_t> rays = config_.rays ? rays_meeting(info.box, parent_rays) : std::vector<uint32_t>{};

  auto make_leaf = [&] {
    nodes_[index].begin = begin;
    nodes_[index].count = count;
    return index;
  };
  if (count == 1 || depth >= config_.max_depth) return make_leaf();

  // Small nodes take the exact sweep even in binned mode: it is cheaper than
  // filling and sweeping 3 x bins bins there, and never worse.
  SweepKey small_keys[3][kSmallSweep];
  std::vector<SweepKey> big_keys;
  SweepOrders orders;
  if (sweeps(count)) {
    if (presorted) {
      orders = *presorted;
    } else {
      if (count > kSmallSweep) big_keys.resize(3 * size_t(count));
      for (int a = 0; a < 3; ++a)
        orders.keys[a] = count > kSmallSweep ? big_keys.data() + size_t(a) * count : small_keys[a];
    }
  }
  Split object_fallback;
  Split best = choose_split(begin, count, capacity, depth, info, orders, rays, &object_fallback);
  const float leaf_cost = config_.t2 * info.weight;
  const bool fits_leaf = count <= config_.max_leaf_size;
  if (fits_leaf && (!best.valid() || leaf_cost <= best.cost)) return make_leaf();
  if (!fits_leaf && best.valid() && leaf_cost <= best.cost) forced_splits_.fetch_add(1);

  bool by_split = false;
  const ChildRanges c = partition_node(best, object_fallback, begin, count, capacity, depth, info, orders, &by_split);
  const uint32_t right_begin = begin + c.left_capacity;
  const uint32_t right_capacity = capacity - c.left_capacity;
  const std::vector<uint32_t>* child_rays = config_.rays ? &rays : nullptr;
  // Spatial splits change the references, so their children sort again.
  SweepKey child_keys[2][3][kSmallSweep];
  SweepOrders child_orders[2];
  const bool presort_children = by_split && best.kind == Split::Kind::Sweep && !config_.spatial_splits &&
                                count <= kSmallSweep && c.left_capacity == c.left_count;
  if (presort_children) split_child_orders(orders, best.axis, count, c.left_count, child_keys, child_orders);
  const SweepOrders* left_sorted = presort_children ? &child_orders[0] : nullptr;
  const SweepOrders* right_sorted = presort_children ? &child_orders[1] : nullptr;
  uint32_t left_node = 0, right_node = 0;
  if (count >= kParallelRecursion) {
    tbb::parallel_invoke(
        [&] { left_node = build(begin, c.left_count, c.left_capacity, depth + 1, child_rays); },
        [&] { right_node = build(right_begin, c.right_count, right_capacity, depth + 1, child_rays); });
  } else {
    left_node = build(begin, c.left_count, c.left_capacity, depth + 1, child_rays, left_sorted);
    right_node = build(right_begin, c.right_count, right_capacity, depth + 1, child_rays, right_sorted);
  }
  // The authors' OSAH puts the child holding more visible references first.
  if (config_.visible_first && nodes_[right_node].visible > nodes_[left_node].visible)
    std::swap(left_node, right_node);
  nodes_[index].left = left_node;
  nodes_[index].right = right_node;
  return index;
}

bool Builder::sweeps(uint32_t count) const {
  // Small nodes take the exact sweep even in binned mode: it is cheaper than
  // filling and sweeping 3 x bins bins there, and never worse.
  const uint32_t sweep_below = config_.spatial_splits ? kExactSweepBelowSpatial : kExactSweepBelow;
  return config_.bins == 0 || count <= sweep_below;
}

Split Builder::find_object_or_sweep(uint32_t begin, uint32_t count, const NodeInfo& info, SweepOrders& orders,
                                    const std::vector<uint32_t>& rays, VisibilitySearch search) const {
  return sweeps(count) ? find_sweep_split(begin, count, info, orders, rays, search)
                       : find_object_split(begin, count, info, rays, search);
}

// SBVH's choice (Stich et al. 2009): a spatial split is looked for only where the
// object split's children overlap by more than sbvh_alpha x the root's area, and
// taken when it is cheaper and its references fit the node's budget.
Split Builder::with_spatial_split(const Split& object, uint32_t begin, uint32_t count, uint32_t capacity,
                                  uint32_t depth, const NodeInfo& info, const std::vector<uint32_t>& rays) const {
  if (!config_.spatial_splits || !object.valid() || capacity <= count || depth < config_.spatial_min_depth ||
      (depth == 0 && !spatial_at_root_))
    return object;
  const Aabb overlap = Aabb::intersection(object.left_box, object.right_box);
  if (overlap.empty() || overlap.area() < config_.sbvh_alpha * root_area_) return object;
  const Split spatial = find_spatial_split(begin, count, info, rays);
  if (spatial.valid() && spatial.cost < object.cost && fits(spatial, capacity)) return spatial;
  return object;
}

// The split a node takes before the leaf test: SAH's (object), SBVH's (object or
// spatial), or under the authors' OSAH rule (Vinkler, Havran and Sochor 2012, as
// NTrace's OcclusionBVHBuilder builds it):
//   - in mixed nodes (0 < visible < all references) above visibility_depth, a
//     visibility split: the best split under P_i = w V_i / V + (1 - w) A_i / A over
//     spatial bins (w = osah_w), or over object bins with the weight w (1 - V / N)
//     without spatial splits. It is taken only when the child holding fewer visible
//     references has more references than the larger child of the best plain split
//     of the same kind (visibility_any_split: always). Otherwise the plain object or
//     spatial split, whichever is cheaper (no overlap test there, as theirs);
//   - elsewhere, SBVH where visible references are and object splits where none
//     are, with spatial splits only from spatial_min_depth (the visibility depth)
//     on: above it, nodes that are all visible or all hidden take object splits.
// *object_fallback: the best object split, should a spatial partition fail.
Split Builder::choose_split(uint32_t begin, uint32_t count, uint32_t capacity, uint32_t depth,
                            const NodeInfo& info, SweepOrders& orders, const std::vector<uint32_t>& rays,
                            Split* object_fallback) const {
  if (!config_.visible) {
    *object_fallback = find_object_or_sweep(begin, count, info, orders, rays);
    return with_spatial_split(*object_fallback, begin, count, capacity, depth, info, rays);
  }
  const bool upper = depth < config_.visibility_depth;
  const bool mixed = info.visible > 0 && info.visible < info.count;
  auto accepted = [&](const Split& visibility, const Split& plain) {
    if (!visibility.valid()) return false;
    if (config_.visibility_any_split) return true;
    const uint32_t hidden_child = visibility.left_visible < visibility.right_visible ? visibility.left_count
                                                                                     : visibility.right_count;
    return hidden_child > std::max(plain.left_count, plain.right_count);
  };
  if (upper && mixed) {
    Split visibility;
    if (config_.spatial_splits) {
      *object_fallback = find_object_or_sweep(begin, count, info, orders, rays);
      const Split spatial = capacity > count
                                ? find_spatial_split(begin, count, info, rays, {config_.osah_w, &visibility})
                                : Split{};
      if (accepted(visibility, spatial) && fits(visibility, capacity)) {
        visibility.visibility = true;
        return visibility;
      }
      if (spatial.valid() && spatial.cost < object_fallback->cost && fits(spatial, capacity)) return spatial;
      return *object_fallback;
    }
    const float w = config_.osah_w * (1.0f - float(info.visible) / float(info.count));
    *object_fallback = find_object_or_sweep(begin, count, info, orders, rays, {w, &visibility});
    if (accepted(visibility, *object_fallback)) {
      visibility.visibility = true;
      return visibility;
    }
    return *object_fallback;
  }
  *object_fallback = find_object_or_sweep(begin, count, info, orders, rays);
  if (info.visible == 0) return *object_fallback;
  return with_spatial_split(*object_fallback, begin, count, capacity, depth, info, rays);
}

Bvh Builder::run(CoreStats* stats) {
  const size_t n = scene_.triangle_count();
  if (n == 0) throw InputError("scene '" + scene_.name + "'", "has no triangles to build a BVH over");
  if (n > kPrimMask) throw InputError("scene '" + scene_.name + "'", "too many triangles (max 2^28)");
  if (config_.max_leaf_size == 0) throw InputError("max_leaf_size", "must be at least 1");
  if (config_.bins == 1 || config_.bins > kMaxBins)
    throw InputError("bins", "must be 0 (full sweep) or 2.." + std::to_string(kMaxBins));
  if (levels_needed(n, config_.max_leaf_size) > config_.max_depth)
    throw InputError("max_depth", "too small for " + std::to_string(n) +
                                      " triangles with max_leaf_size " +
                                      std::to_string(config_.max_leaf_size));
  if (config_.weights && config_.weights->size() != n)
    throw InputError("weights", "one weight per triangle expected");
  if (config_.visible && config_.visible->size() != n)
    throw InputError("visibility", "one flag per triangle expected");
  if (config_.rays && !(std::isfinite(config_.rdh_prior) && config_.rdh_prior > 0))
    throw InputError("rdh_prior", "must be a positive finite number");

  // The authors' OSAH takes its root split as its rules give it (no second build).
  if (!config_.spatial_splits || config_.visible) return run_once(true, stats);
  // The greedy choice at the root can be wrong: a spatial split that is cheaper
  // by the SAH of one level can give a dearer tree (interior). When the root was
  // split spatially, build the tree again with an object split at the root and
  // keep the tree with the lower SAH cost (the builder's own, weighted cost).
  CoreStats first_stats;
  Bvh first = run_once(true, &first_stats);
  if (!root_split_spatial_) {
    if (stats) *stats = first_stats;
    return first;
  }
  CoreStats second_stats;
  Bvh second = run_once(false, &second_stats);
  static const std::vector<float> kNoWeights;
  const std::vector<float>& w = config_.weights ? *config_.weights : kNoWeights;
  const bool keep_second =
      sah_cost(second, config_.t1, config_.t2, w) < sah_cost(first, config_.t1, config_.t2, w);
  if (stats) {
    *stats = keep_second ? second_stats : first_stats;
    stats->working_bytes = std::max(first_stats.working_bytes, second_stats.working_bytes) +
                           first.nodes.capacity() * sizeof(BvhNode) +
                           first.prim_refs.capacity() * sizeof(uint32_t);
  }
  return keep_second ? second : first;
}

Bvh Builder::run_once(bool spatial_at_root, CoreStats* stats) {
  const size_t n = scene_.triangle_count();
  spatial_at_root_ = spatial_at_root;
  root_split_spatial_ = false;
  forced_splits_ = 0, median_splits_ = 0, ray_node_pairs_ = 0, visibility_splits_ = 0;
  nodes_.clear();
  const uint64_t capacity64 =
      config_.spatial_splits
          ? std::max<uint64_t>(n, uint64_t(std::floor(double(config_.reference_budget) * double(n))))
          : n;
  const uint32_t capacity = uint32_t(std::min<uint64_t>(capacity64, kPrimMask));
  refs_.resize(capacity);
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    const Aabb box = scene_.triangle_bounds(uint32_t(i));
    Ref& r = refs_[i];
    r.lo = box.lo;
    r.hi = box.hi;
    r.tag = uint32_t(i) | (config_.visible && (*config_.visible)[i] ? kVisibleBit : 0u);
    r.weight = config_.weights ? (*config_.weights)[i] : 1.0f;
  });
  nodes_.reserve(2 * n / std::max<uint32_t>(1, config_.max_leaf_size) + 16);
  root_area_ = scene_.bounds().area();
  build(0, uint32_t(n), capacity, 0, nullptr);

  // Depth-first flatten: node indices and prim_ref order depend only on the tree.
  Bvh bvh;
  bvh.nodes.reserve(nodes_.size());
  bvh.prim_refs.reserve(n);
  bvh.nodes.push_back(BvhNode{nodes_[0].box, 0, 0});
  std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};  // (temp node, final node)
  std::vector<uint32_t> leaf_prims;
  while (!stack.empty()) {
    const auto [temp, final_index] = stack.back();
    stack.pop_back();
    const TempNode& t = nodes_[temp];
    if (t.left == ~0u) {
      leaf_prims.clear();
      for (uint32_t i = t.begin; i < t.begin + t.count; ++i) leaf_prims.push_back(refs_[i].prim());
      if (config_.spatial_splits) {
        // Two pieces of one split triangle can meet again in one leaf: test it once.
        std::sort(leaf_prims.begin(), leaf_prims.end());
        leaf_prims.erase(std::unique(leaf_prims.begin(), leaf_prims.end()), leaf_prims.end());
      }
      bvh.nodes[final_index].index = uint32_t(bvh.prim_refs.size());
      bvh.nodes[final_index].count = uint32_t(leaf_prims.size());
      bvh.prim_refs.insert(bvh.prim_refs.end(), leaf_prims.begin(), leaf_prims.end());
      continue;
    }
    const uint32_t first_child = uint32_t(bvh.nodes.size());
    bvh.nodes[final_index].index = first_child;
    bvh.nodes[final_index].count = 0;
    bvh.nodes[final_index].children = 2;
    bvh.nodes.push_back(BvhNode{nodes_[t.left].box, 0, 0});
    bvh.nodes.push_back(BvhNode{nodes_[t.right].box, 0, 0});
    stack.push_back({t.right, first_child + 1});
    stack.push_back({t.left, first_child});
  }
  if (stats) {
    stats->references = bvh.prim_refs.size();
    stats->forced_splits = forced_splits_.load();
    stats->median_splits = median_splits_.load();
    stats->visibility_splits = visibility_splits_.load();
    stats->ray_node_pairs = ray_node_pairs_.load();
    stats->working_bytes = refs_.capacity() * sizeof(Ref) + nodes_.size() * sizeof(TempNode) +
                           bvh.nodes.capacity() * sizeof(BvhNode) +
                           bvh.prim_refs.capacity() * sizeof(uint32_t);
  }
  return bvh;
}

}  // namespace

Bvh build_weighted_sah(const Scene& scene, const CoreConfig& config, CoreStats* stats) {
  Builder builder(scene, config);
  auto build = [&] {
    Bvh bvh = builder.run(stats);
    if (config.treelet_passes == 0) return bvh;
    TreeletConfig treelets;
    treelets.t1 = config.t1, treelets.t2 = config.t2;
    treelets.leaves = config.treelet_leaves, treelets.passes = config.treelet_passes;
    treelets.max_leaf_size = config.max_leaf_size;
    treelets.weights = config.weights;
    TreeletStats treelet_stats;
    bvh = restructure_treelets(bvh, treelets, &treelet_stats);
    if (stats) stats->treelets_restructured = treelet_stats.restructured;
    return bvh;
  };
  if (config.threads == 0) return build();
  tbb::task_arena arena{int(config.threads)};
  Bvh result;
  arena.execute([&] { result = build(); });
  return result;
}

}  // namespace rtsim::detail
