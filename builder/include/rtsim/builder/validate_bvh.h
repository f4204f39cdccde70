#pragma once
// Structural checks every built tree must pass, whatever the builder:
//   - every inner node has 2..max_width children;
//   - every node has a finite, non-empty box; child boxes lie inside their parent's;
//   - every node is reached exactly once from the root (no cycles, no orphans);
//   - leaves hold 1..max_leaf_size references, all inside prim_refs and naming
//     real triangles; a leaf box holds its triangles (with split references: it
//     overlaps them, and the leaves of each triangle together span its box);
//   - every triangle is referenced; depth (root = 0) <= max_depth;
//   - references: exactly N without split references, at most budget x N with them.
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

struct BvhLimits {
  uint32_t max_leaf_size = 4;
  uint32_t max_depth = 64;
  uint32_t max_width = 2;  // children per node (BuildParams::width)
  bool split_references = false;  // SBVH / embree-sbvh: a leaf may hold part of a triangle
  double reference_budget = 1.3;  // with split references: prim_refs <= budget x N
};

struct BvhValidation {
  std::vector<std::string> problems;  // the first few problems found, human-readable
  uint64_t problem_count = 0;
  uint32_t max_depth = 0;
  bool ok() const { return problem_count == 0; }
  std::string summary() const;  // "ok" or the problems, one per line
};

BvhValidation validate_bvh(const Bvh& bvh, const Scene& scene, const BvhLimits& limits);

}  // namespace rtsim
