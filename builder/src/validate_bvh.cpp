#include <rtsim/builder/validate_bvh.h>

#include <cmath>
#include <string>

namespace rtsim {

namespace {
constexpr size_t kMaxListedProblems = 20;

std::string box_text(const Aabb& b) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "[(%g,%g,%g) - (%g,%g,%g)]", b.lo.x, b.lo.y, b.lo.z, b.hi.x,
                b.hi.y, b.hi.z);
  return buf;
}
}  // namespace

std::string BvhValidation::summary() const {
  if (ok()) return "ok";
  std::string text;
  for (const std::string& p : problems) text += p + "\n";
  if (problem_count > problems.size())
    text += "... and " + std::to_string(problem_count - problems.size()) + " more\n";
  return text;
}

BvhValidation validate_bvh(const Bvh& bvh, const Scene& scene, const BvhLimits& limits) {
  BvhValidation result;
  auto problem = [&](const std::string& text) {
    if (result.problems.size() < kMaxListedProblems) result.problems.push_back(text);
    ++result.problem_count;
  };
  const size_t n = scene.triangle_count();
  if (bvh.nodes.empty()) {
    problem("the tree has no nodes");
    return result;
  }
  std::vector<uint8_t> node_seen(bvh.nodes.size(), 0);
  std::vector<uint32_t> tri_refs(n, 0);
  std::vector<Aabb> tri_span(limits.split_references ? n : 0);
  struct Item {
    uint32_t node, depth;
  };
  std::vector<Item> stack{{0, 0}};
  while (!stack.empty()) {
    const Item item = stack.back();
    stack.pop_back();
    const std::string where = "node " + std::to_string(item.node);
    if (node_seen[item.node]) {
      problem(where + ": reached twice (cycle or shared child)");
      continue;
    }
    node_seen[item.node] = 1;
    const BvhNode& node = bvh.nodes[item.node];
    result.max_depth = std::max(result.max_depth, item.depth);
    if (item.depth > limits.max_depth)
      problem(where + ": depth " + std::to_string(item.depth) + " exceeds max " +
              std::to_string(limits.max_depth));
    if (node.bounds.empty() || !is_finite(node.bounds.lo) || !is_finite(node.bounds.hi))
      problem(where + ": empty or non-finite box " + box_text(node.bounds));
    if (!node.is_leaf()) {
      if (node.children < 2 || node.children > limits.max_width) {
        problem(where + ": " + std::to_string(node.children) + " children (allowed 2.." +
                std::to_string(limits.max_width) + ")");
        continue;
      }
      if (uint64_t(node.index) + node.children > bvh.nodes.size() || node.index <= item.node) {
        problem(where + ": child index " + std::to_string(node.index) + " out of range");
        continue;
      }
      for (uint32_t c = node.index; c < node.index + node.children; ++c) {
        if (!node.bounds.contains(bvh.nodes[c].bounds))
          problem(where + ": child " + std::to_string(c) + " box " +
                  box_text(bvh.nodes[c].bounds) + " outside " + box_text(node.bounds));
        stack.push_back({c, item.depth + 1});
      }
      continue;
    }
    if (node.count > limits.max_leaf_size)
      problem(where + ": leaf holds " + std::to_string(node.count) + " > max " +
              std::to_string(limits.max_leaf_size));
    if (uint64_t(node.index) + node.count > bvh.prim_refs.size()) {
      problem(where + ": leaf references past prim_refs");
      continue;
    }
    for (uint32_t i = node.index; i < node.index + node.count; ++i) {
      const uint32_t tri = bvh.prim_refs[i];
      if (tri >= n) {
        problem(where + ": triangle " + std::to_string(tri) + " does not exist");
        continue;
      }
      ++tri_refs[tri];
      const Aabb tri_box = scene.triangle_bounds(tri);
      if (!limits.split_references) {
        if (!node.bounds.contains(tri_box))
          problem(where + ": triangle " + std::to_string(tri) + " outside the leaf box");
      } else {
        const Aabb overlap = Aabb::intersection(node.bounds, tri_box);
        if (overlap.empty())
          problem(where + ": triangle " + std::to_string(tri) + " does not touch the leaf box");
        tri_span[tri].extend(overlap);
      }
    }
  }
  for (size_t i = 0; i < bvh.nodes.size(); ++i)
    if (!node_seen[i]) {
      problem("node " + std::to_string(i) + ": not reachable from the root");
      break;
    }
  for (size_t t = 0; t < n; ++t) {
    if (tri_refs[t] == 0) {
      problem("triangle " + std::to_string(t) + ": not reachable");
    } else if (!limits.split_references && tri_refs[t] > 1) {
      problem("triangle " + std::to_string(t) + ": referenced " + std::to_string(tri_refs[t]) +
              " times");
    } else if (limits.split_references && !tri_span[t].contains(scene.triangle_bounds(uint32_t(t)))) {
      problem("triangle " + std::to_string(t) + ": its leaves do not span its box");
    }
  }
  const double allowed = limits.split_references ? std::floor(limits.reference_budget * double(n))
                                                 : double(n);
  if (double(bvh.prim_refs.size()) > std::max(allowed, double(n)))
    problem(std::to_string(bvh.prim_refs.size()) + " references exceed the budget of " +
            std::to_string(uint64_t(allowed)));
  return result;
}

}  // namespace rtsim
