#include <rtsim/builder/collapse.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <limits>
#include <string>

namespace rtsim {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

class Collapser {
 public:
  Collapser(const Bvh& binary, const CollapseParams& p)
      : in_(binary), p_(p), w_(p.width), count_(binary.nodes.size()) {}

  Bvh run(CollapseReport* report) {
    reach_probabilities();
    solve();
    Bvh out = rebuild();
    if (report) {
      report->cost = cost(0, 1);
      report->binary_nodes = count_;
      report->wide_nodes = out.nodes.size();
    }
    return out;
  }

 private:
  const BvhNode& node(size_t i) const { return in_.nodes[i]; }
  double& cost(size_t n, uint32_t slots) { return cost_[n * (w_ + 1) + slots]; }
  uint8_t& split(size_t n, uint32_t slots) { return split_[n * (w_ + 1) + slots]; }

  // r(n): products of the builder's child probabilities from the root.
  void reach_probabilities() {
    reach_.assign(count_, 0.0);
    reach_[0] = 1.0;
    for (size_t i = 0; i < count_; ++i) {
      const BvhNode& n = node(i);
      if (n.is_leaf()) continue;
      const double area = n.bounds.area();
      for (uint32_t c = n.index; c < n.index + 2; ++c)
        reach_[c] = reach_[i] * (area > 0 ? node(c).bounds.area() / area : 1.0);
    }
  }

  // The distinct triangles below n, in leaf order (split references of one
  // triangle that meet in a merged leaf are tested once).
  void gather(size_t n, std::vector<uint32_t>* prims) const {
    const BvhNode& b = node(n);
    if (b.is_leaf()) {
      for (uint32_t k = b.index; k < b.index + b.count; ++k) {
        const uint32_t t = in_.prim_refs[k];
        if (std::find(prims->begin(), prims->end(), t) == prims->end()) prims->push_back(t);
      }
      return;
    }
    gather(b.index, prims);
    gather(b.index + 1, prims);
  }

  double leaf_weight(const std::vector<uint32_t>& prims) const {
    double w = 0;
    for (uint32_t t : prims) w += p_.weights.empty() ? 1.0 : double(p_.weights[t]);
    return w;
  }

  void solve() {
    cost_.assign(count_ * (w_ + 1), kInfinity);
    split_.assign(count_ * (w_ + 1), 0);
    leaf_.assign(count_, 0);
    refs_.assign(count_, 0);
    inner_split_.assign(count_, 0);
    std::vector<uint32_t> prims;
    // Children come after their parent: one backward pass is bottom-up.
    for (size_t n = count_; n-- > 0;) {
      const BvhNode& b = node(n);
      double leaf_cost = kInfinity;
      refs_[n] = b.is_leaf() ? b.count : refs_[b.index] + refs_[b.index + 1];
      if (refs_[n] <= p_.max_leaf_size) {
        prims.clear();
        gather(n, &prims);
        leaf_cost = reach_[n] * double(p_.t2) * leaf_weight(prims);
      }
      if (b.is_leaf()) {
        if (b.count > p_.max_leaf_size)
          throw InputError("max_leaf_size", "a leaf of the binary tree holds " +
                                                std::to_string(b.count) + " triangles, more than the " +
                                                std::to_string(p_.max_leaf_size) +
                                                " the wide format's leaves hold (build with the format's limit)");
        leaf_[n] = 1;
        for (uint32_t i = 1; i <= w_; ++i) cost(n, i) = leaf_cost;  // split 0: "fewer slots"
        continue;
      }
      const uint32_t l = b.index, r = b.index + 1;
      // D(n, j) into split(n, j) and a scratch row.
      double d[kMaxBvhWidth + 1];
      for (uint32_t j = 2; j <= w_; ++j) {
        d[j] = kInfinity;
        for (uint32_t k = 1; k < j; ++k) {
          const double c = cost(l, k) + cost(r, j - k);
          if (c < d[j]) d[j] = c, split(n, j) = uint8_t(k);
        }
      }
      const double inner_cost = reach_[n] * 2.0 * double(p_.t1) + d[w_];
      if (leaf_cost <= inner_cost) {
        leaf_[n] = 1;
        cost(n, 1) = leaf_cost;
      } else {
        cost(n, 1) = inner_cost;
      }
      inner_split_[n] = split(n, w_);
      for (uint32_t i = 2; i <= w_; ++i) {
        if (d[i] < cost(n, i - 1)) {
          cost(n, i) = d[i];
        } else {
          cost(n, i) = cost(n, i - 1);
          split(n, i) = 0;
        }
      }
    }
  }

  // The slots that C(n, slots) chose, in binary left-to-right order.
  void emit(size_t n, uint32_t slots, std::vector<uint32_t>* out) {
    while (slots > 1 && split(n, slots) == 0) --slots;
    if (slots == 1) {
      out->push_back(uint32_t(n));
      return;
    }
    const uint32_t k = split(n, slots);
    emit(node(n).index, k, out);
    emit(node(n).index + 1, slots - k, out);
  }

  Bvh rebuild() {
    Bvh out;
    out.nodes.reserve(count_);
    out.prim_refs.reserve(in_.prim_refs.size());
    out.nodes.push_back(BvhNode{node(0).bounds, 0, 0, 0});
    struct Item {
      uint32_t binary, wide;
    };
    std::vector<Item> stack{{0, 0}};
    std::vector<uint32_t> slots, prims;
    while (!stack.empty()) {
      const Item item = stack.back();
      stack.pop_back();
      BvhNode& w = out.nodes[item.wide];
      if (leaf_[item.binary]) {
        prims.clear();
        gather(item.binary, &prims);
        w.index = uint32_t(out.prim_refs.size());
        w.count = uint32_t(prims.size());
        out.prim_refs.insert(out.prim_refs.end(), prims.begin(), prims.end());
        continue;
      }
      slots.clear();
      const BvhNode& b = node(item.binary);
      const uint32_t k = inner_split_[item.binary];
      emit(b.index, k, &slots);
      emit(b.index + 1, w_ - k, &slots);
      const uint32_t first = uint32_t(out.nodes.size());
      out.nodes[item.wide].index = first;
      out.nodes[item.wide].count = 0;
      out.nodes[item.wide].children = uint32_t(slots.size());
      for (uint32_t s : slots) out.nodes.push_back(BvhNode{node(s).bounds, 0, 0, 0});
      for (size_t c = slots.size(); c-- > 0;) stack.push_back({slots[c], first + uint32_t(c)});
    }
    return out;
  }

  const Bvh& in_;
  const CollapseParams& p_;
  const uint32_t w_;
  const size_t count_;
  std::vector<double> reach_, cost_;
  std::vector<uint8_t> split_, leaf_, inner_split_;
  std::vector<uint64_t> refs_;
};

}  // namespace

Bvh collapse_bvh(const Bvh& binary, const CollapseParams& params, CollapseReport* report) {
  if (params.width < 2 || params.width > kMaxBvhWidth)
    throw InputError("width", "must be 2.." + std::to_string(kMaxBvhWidth) + ", got " +
                                  std::to_string(params.width));
  if (params.max_leaf_size < 1) throw InputError("max_leaf_size", "must be at least 1");
  if (binary.empty()) throw InputError("bvh", "the tree to collapse has no nodes");
  uint32_t max_prim = 0;
  for (uint32_t t : binary.prim_refs) max_prim = std::max(max_prim, t);
  if (!params.weights.empty() && params.weights.size() <= max_prim)
    throw InputError("weights", "fewer entries than the tree's triangles");
  for (const BvhNode& n : binary.nodes)
    if (!n.is_leaf() && n.children != 2)
      throw InputError("bvh", "the tree to collapse must be binary (a node has " +
                                  std::to_string(n.children) + " children)");
  Collapser c(binary, params);
  return c.run(report);
}

}  // namespace rtsim
