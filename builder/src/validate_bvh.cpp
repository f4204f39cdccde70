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
  const bool two_level = bvh.two_level();
  if (two_level != scene.instanced()) {
    problem(two_level ? "a two-level tree for a flat scene" : "a one-level tree for an instanced scene");
    return result;
  }
  if (two_level && bvh.blas_roots.size() != scene.meshes.size()) {
    problem(std::to_string(bvh.blas_roots.size()) + " BLAS roots for " + std::to_string(scene.meshes.size()) +
            " meshes");
    return result;
  }
  std::vector<uint8_t> node_seen(bvh.nodes.size(), 0);
  std::vector<uint32_t> tri_refs(n, 0);
  std::vector<uint32_t> instance_refs(scene.instances.size(), 0);
  std::vector<Aabb> tri_span(limits.split_references ? n : 0);
  uint64_t tlas_refs = 0;  // a TLAS's references name instances, not triangles
  struct Item {
    uint32_t node, depth;
  };
  // One tree from `root`: the TLAS (nodes below tlas_nodes, one instance per leaf,
  // whose placed box the leaf holds), a BLAS (nodes from tlas_nodes on, triangles of
  // mesh `mesh` in object space) or the one-level tree (mesh ~0: every triangle).
  constexpr uint32_t kTlas = ~1u, kAll = ~0u;
  const auto walk = [&](uint32_t root, uint32_t mesh) {
    const std::string tree = mesh == kTlas ? "TLAS " : mesh == kAll ? "" : "BLAS of mesh " + std::to_string(mesh) + " ";
    const bool in_tlas = mesh == kTlas;
    uint32_t first_tri = 0, end_tri = uint32_t(n);
    if (mesh != kTlas && mesh != kAll)
      first_tri = scene.meshes[mesh].first_triangle, end_tri = first_tri + scene.meshes[mesh].triangle_count;
    std::vector<Item> stack{{root, 0}};
    while (!stack.empty()) {
      const Item item = stack.back();
      stack.pop_back();
      const std::string where = tree + "node " + std::to_string(item.node);
      if (two_level && (item.node < bvh.tlas_nodes) != in_tlas) {
        problem(where + ": " + (in_tlas ? "beyond the TLAS's nodes" : "inside the TLAS's nodes"));
        continue;
      }
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
      if (node.count > (in_tlas ? 1u : limits.max_leaf_size))
        problem(where + ": leaf holds " + std::to_string(node.count) + " > max " +
                std::to_string(in_tlas ? 1u : limits.max_leaf_size));
      if (uint64_t(node.index) + node.count > bvh.prim_refs.size()) {
        problem(where + ": leaf references past prim_refs");
        continue;
      }
      for (uint32_t i = node.index; i < node.index + node.count; ++i) {
        const uint32_t ref = bvh.prim_refs[i];
        if (in_tlas) {
          if (ref >= scene.instances.size()) {
            problem(where + ": instance " + std::to_string(ref) + " does not exist");
            continue;
          }
          ++instance_refs[ref];
          ++tlas_refs;
          if (bvh.blas_roots[scene.instances[ref].mesh] == Bvh::kNoBlas)
            problem(where + ": instance " + std::to_string(ref) + "'s mesh has no BLAS");
          if (!node.bounds.contains(scene.instance_bounds(ref)))
            problem(where + ": instance " + std::to_string(ref) + " outside the leaf box");
          continue;
        }
        if (ref < first_tri || ref >= end_tri) {
          problem(where + ": triangle " + std::to_string(ref) +
                  (ref < n ? " is not one of this tree's" : " does not exist"));
          continue;
        }
        ++tri_refs[ref];
        const Aabb tri_box = scene.triangle_bounds(ref);
        if (!limits.split_references) {
          if (!node.bounds.contains(tri_box))
            problem(where + ": triangle " + std::to_string(ref) + " outside the leaf box");
        } else {
          const Aabb overlap = Aabb::intersection(node.bounds, tri_box);
          if (overlap.empty())
            problem(where + ": triangle " + std::to_string(ref) + " does not touch the leaf box");
          tri_span[ref].extend(overlap);
        }
      }
    }
  };
  if (!two_level) {
    walk(0, kAll);
  } else {
    walk(0, kTlas);
    for (uint32_t m = 0; m < bvh.blas_roots.size(); ++m) {
      const uint32_t root = bvh.blas_roots[m];
      if (root == Bvh::kNoBlas) {
        if (scene.meshes[m].triangle_count > 0) problem("mesh " + std::to_string(m) + ": has triangles but no BLAS");
        continue;
      }
      if (root < bvh.tlas_nodes || root >= bvh.nodes.size()) {
        problem("mesh " + std::to_string(m) + ": BLAS root " + std::to_string(root) + " out of range");
        continue;
      }
      walk(root, m);
    }
    for (size_t i = 0; i < instance_refs.size(); ++i) {
      const bool places = scene.meshes[scene.instances[i].mesh].triangle_count > 0;
      if (places ? instance_refs[i] != 1 : instance_refs[i] != 0)
        problem("instance " + std::to_string(i) + ": referenced " + std::to_string(instance_refs[i]) +
                " times by the TLAS");
    }
  }
  for (size_t i = 0; i < bvh.nodes.size(); ++i)
    if (!node_seen[i]) {
      problem("node " + std::to_string(i) + ": not reachable from " + (two_level ? "a root" : "the root"));
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
  const uint64_t triangle_refs = bvh.prim_refs.size() - tlas_refs;
  const double allowed = limits.split_references ? std::floor(limits.reference_budget * double(n))
                                                 : double(n);
  if (double(triangle_refs) > std::max(allowed, double(n)))
    problem(std::to_string(triangle_refs) + " references exceed the budget of " +
            std::to_string(uint64_t(allowed)));
  return result;
}

}  // namespace rtsim
