#include "treelet.h"

#include <rtsim/workloads/error.h>

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <atomic>
#include <limits>

namespace rtsim::detail {

namespace {
constexpr uint32_t kNone = ~0u;
constexpr uint32_t kParallelSubtree = 4096;  // nodes; smaller subtrees stay on one task
constexpr uint32_t kMaxLeaves = 8;

class Restructurer {
 public:
  Restructurer(const Bvh& bvh, const TreeletConfig& config) : in_(bvh), config_(config) {
    const size_t n = bvh.nodes.size();
    left_.assign(n, kNone), right_.assign(n, kNone);
    box_.resize(n), cost_.resize(n), height_.assign(n, 0), size_.assign(n, 1);
    count_.assign(n, 0), weight_.assign(n, 0), merged_.resize(n);
    // Children have larger indices than their parent: one backward pass is bottom-up.
    for (size_t i = n; i-- > 0;) {
      const BvhNode& node = bvh.nodes[i];
      box_[i] = node.bounds;
      const double area = node.bounds.area();
      if (node.is_leaf()) {
        double w = 0;
        for (uint32_t k = node.index; k < node.index + node.count; ++k)
          w += config.weights ? double((*config.weights)[bvh.prim_refs[k]]) : 1.0;
        cost_[i] = double(config.t2) * w * area;
        count_[i] = node.count, weight_[i] = w;
        continue;
      }
      if (node.children != 2) throw InputError("treelet restructuring", "needs a binary tree");
      left_[i] = node.index, right_[i] = node.index + 1;
      update(uint32_t(i));
    }
  }

  void run(TreeletStats* stats) {
    for (uint32_t pass = 0; pass < config_.passes; ++pass) optimise(0);
    if (stats) stats->restructured = restructured_.load();
  }

  // Depth-first flatten, the builders' layout: a node's children adjacent, the left
  // subtree first.
  Bvh flatten() const {
    Bvh out;
    out.nodes.reserve(in_.nodes.size());
    out.prim_refs.reserve(in_.prim_refs.size());
    out.nodes.push_back(BvhNode{box_[0], 0, 0, 0});
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0u, 0u}};  // (node here, node out)
    while (!stack.empty()) {
      const auto [node, at] = stack.back();
      stack.pop_back();
      if (left_[node] == kNone) {
        out.nodes[at].index = uint32_t(out.prim_refs.size());
        out.nodes[at].count = count_[node];
        if (!merged_[node].empty()) {
          out.prim_refs.insert(out.prim_refs.end(), merged_[node].begin(), merged_[node].end());
        } else {
          const BvhNode& leaf = in_.nodes[node];
          out.prim_refs.insert(out.prim_refs.end(), in_.prim_refs.begin() + leaf.index,
                               in_.prim_refs.begin() + leaf.index + leaf.count);
        }
        continue;
      }
      const uint32_t first = uint32_t(out.nodes.size());
      out.nodes[at].index = first;
      out.nodes[at].children = 2;
      out.nodes.push_back(BvhNode{box_[left_[node]], 0, 0, 0});
      out.nodes.push_back(BvhNode{box_[right_[node]], 0, 0, 0});
      stack.push_back({right_[node], first + 1});
      stack.push_back({left_[node], first});
    }
    return out;
  }

 private:
  bool inner(uint32_t i) const { return left_[i] != kNone; }

  void update(uint32_t i) {
    const uint32_t l = left_[i], r = right_[i];
    cost_[i] = 2.0 * double(config_.t1) * double(box_[i].area()) + cost_[l] + cost_[r];
    height_[i] = 1 + std::max(height_[l], height_[r]);
    size_[i] = 1 + size_[l] + size_[r];
  }

  void optimise(uint32_t node) {
    if (!inner(node)) return;
    if (size_[node] >= kParallelSubtree) {
      tbb::parallel_invoke([&] { optimise(left_[node]); }, [&] { optimise(right_[node]); });
    } else {
      optimise(left_[node]);
      optimise(right_[node]);
    }
    update(node);
    restructure(node);
  }

  // The treelet below `root`: grow it by opening its largest inner leaf until it has
  // config_.leaves leaves, then rebuild its inner nodes in the cheapest topology.
  void restructure(uint32_t root) {
    uint32_t leaf[kMaxLeaves], pool[kMaxLeaves];
    uint32_t leaves = 2, pooled = 1;
    leaf[0] = left_[root], leaf[1] = right_[root], pool[0] = root;
    while (leaves < config_.leaves) {
      int open = -1;
      float open_area = -1;
      for (uint32_t i = 0; i < leaves; ++i)
        if (inner(leaf[i]) && box_[leaf[i]].area() > open_area) open = int(i), open_area = box_[leaf[i]].area();
      if (open < 0) break;
      const uint32_t opened = leaf[open];
      pool[pooled++] = opened;
      leaf[open] = left_[opened];
      leaf[leaves++] = right_[opened];
    }
    if (leaves < 3) return;  // two leaves have one topology

    // best[s]: least cost of a subtree over the leaves in bit set s; split[s] its left part.
    const uint32_t sets = 1u << leaves, full = sets - 1;
    Aabb box[1u << kMaxLeaves];
    double best[1u << kMaxLeaves];
    uint32_t split[1u << kMaxLeaves], height[1u << kMaxLeaves], prims[1u << kMaxLeaves];
    double weight[1u << kMaxLeaves];
    const double node_cost = 2.0 * double(config_.t1);
    for (uint32_t s = 1; s < sets; ++s) {
      const uint32_t low = s & (0u - s);
      if (s == low) {
        const uint32_t i = uint32_t(__builtin_ctz(s));
        box[s] = box_[leaf[i]], best[s] = cost_[leaf[i]], height[s] = height_[leaf[i]];
        prims[s] = inner(leaf[i]) ? kNone : count_[leaf[i]], weight[s] = weight_[leaf[i]];
        split[s] = 0;
        continue;
      }
      box[s] = box[s ^ low];
      box[s].extend(box[low]);
      // Each unordered split {p, s ^ p} once: p holds s's lowest leaf.
      double least = std::numeric_limits<double>::infinity();
      uint32_t chosen = 0;
      for (uint32_t p = (s - 1) & s; p; p = (p - 1) & s) {
        if (!(p & low)) continue;
        const double c = best[p] + best[s ^ p];
        if (c < least) least = c, chosen = p;
      }
      best[s] = node_cost * double(box[s].area()) + least;
      split[s] = chosen;
      height[s] = 1 + std::max(height[chosen], height[s ^ chosen]);
      // Or one leaf of all of them, when they are leaves that fit in one (split 0).
      prims[s] = prims[low] == kNone || prims[s ^ low] == kNone ? kNone : prims[low] + prims[s ^ low];
      weight[s] = weight[low] + weight[s ^ low];
      if (prims[s] <= config_.max_leaf_size) {
        const double as_leaf = double(config_.t2) * weight[s] * double(box[s].area());
        if (as_leaf < best[s]) best[s] = as_leaf, split[s] = 0, height[s] = 0;
      }
    }
    // Take it only when clearly cheaper (no churn on rounding) and no taller than the
    // subtree it replaces. Unbounded, the least-SAH treelets grow chains: on
    // black_forest the SAH cost fell 9% but primary rays took 12-22% more ops
    // (docs/build-speed.md). No leaf gets deeper, so max_depth holds too.
    if (!(best[full] < cost_[root] * (1.0 - 1e-9)) || height[full] > height_[root]) return;
    uint32_t next = 1;  // pool[0] stays the root
    rebuild(full, root, leaf, pool, &next, box, split);
    ++restructured_;
  }

  uint32_t rebuild(uint32_t s, uint32_t node, const uint32_t* leaf, const uint32_t* pool, uint32_t* next,
                   const Aabb* box, const uint32_t* split) {
    if (split[s] == 0) {  // the leaves of s merged into one
      merge(s, node, leaf, box[s]);
      return node;
    }
    const uint32_t parts[2] = {split[s], s ^ split[s]};
    uint32_t child[2];
    for (int c = 0; c < 2; ++c) {
      const uint32_t p = parts[c];
      child[c] = (p & (p - 1)) == 0 ? leaf[__builtin_ctz(p)]
                                    : rebuild(p, pool[(*next)++], leaf, pool, next, box, split);
    }
    left_[node] = child[0], right_[node] = child[1];
    box_[node] = box[s];
    update(node);
    return node;
  }

  std::vector<uint32_t> prims_of(uint32_t leaf) const {
    if (!merged_[leaf].empty()) return merged_[leaf];
    const BvhNode& n = in_.nodes[leaf];
    return std::vector<uint32_t>(in_.prim_refs.begin() + n.index, in_.prim_refs.begin() + n.index + n.count);
  }

  // `node` becomes one leaf of the treelet leaves in s (sorted and deduplicated: two
  // pieces of one split triangle are tested once).
  void merge(uint32_t s, uint32_t node, const uint32_t* leaf, const Aabb& box) {
    std::vector<uint32_t> prims;
    for (uint32_t rest = s; rest; rest &= rest - 1) {
      const std::vector<uint32_t> p = prims_of(leaf[__builtin_ctz(rest)]);
      prims.insert(prims.end(), p.begin(), p.end());
    }
    std::sort(prims.begin(), prims.end());
    prims.erase(std::unique(prims.begin(), prims.end()), prims.end());
    double w = 0;
    for (uint32_t t : prims) w += config_.weights ? double((*config_.weights)[t]) : 1.0;
    left_[node] = right_[node] = kNone;
    box_[node] = box;
    count_[node] = uint32_t(prims.size()), weight_[node] = w;
    cost_[node] = double(config_.t2) * w * double(box.area());
    height_[node] = 0, size_[node] = 1;
    merged_[node] = std::move(prims);
  }

  const Bvh& in_;
  const TreeletConfig& config_;
  std::vector<uint32_t> left_, right_, height_, size_;
  std::vector<Aabb> box_;
  std::vector<double> cost_, weight_;
  std::vector<uint32_t> count_;
  std::vector<std::vector<uint32_t>> merged_;  // a merged leaf's triangles
  std::atomic<uint64_t> restructured_{0};
};
}  // namespace

Bvh restructure_treelets(const Bvh& bvh, const TreeletConfig& config, TreeletStats* stats) {
  if (config.leaves < 3 || config.leaves > kMaxLeaves)
    throw InputError("treelet_leaves", "must be 3.." + std::to_string(kMaxLeaves));
  if (bvh.nodes.empty()) return bvh;
  Restructurer r(bvh, config);
  r.run(stats);
  return r.flatten();
}

}  // namespace rtsim::detail
