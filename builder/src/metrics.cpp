#include <rtsim/builder/metrics.h>

#include <nlohmann/json.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <utility>

namespace rtsim {

namespace {

// One Sutherland-Hodgman pass: keeps the part of the polygon with p[Axis] >= bound
// (Above) or <= bound and returns its vertex count. Written without branches on
// which side a vertex lies (the sides are data, not predictable): every edge
// computes its crossing and stores it, and only the index decides what is kept.
template <int Axis, bool Above>
int clip_pass(const dvec3* poly, int count, double bound, dvec3* next) {
  auto inside = [bound](const dvec3& p) { return Above ? p[Axis] >= bound : p[Axis] <= bound; };
  int out = 0;
  bool pin = inside(poly[0]);
  for (int i = 0; i < count; ++i) {
    const dvec3& p = poly[i];
    const dvec3& q = poly[i + 1 == count ? 0 : i + 1];
    const bool qin = inside(q);
    next[out] = p;
    out += pin;
    const double t = (bound - p[Axis]) / (q[Axis] - p[Axis]);  // unused when no crossing
    dvec3 x = p + t * (q - p);
    x[Axis] = bound;
    next[out] = x;
    out += pin != qin;
    pin = qin;
  }
  return out;
}

// Area of the part of triangle (a, b, c), whose box is `own`, inside `box`
// (Sutherland-Hodgman, the lo planes x, y, z, then the hi planes). Only the planes
// that cut the triangle's box clip: the others hold every vertex.
double clipped_area(const vec3& a, const vec3& b, const vec3& c, const Aabb& own, const Aabb& box) {
  // A triangle clipped by 6 planes has at most 9 vertices; a pass writes one past.
  dvec3 buffer_a[16], buffer_b[16];
  dvec3* poly = buffer_a;
  dvec3* next = buffer_b;
  int count = 3;
  poly[0] = dvec3(a), poly[1] = dvec3(b), poly[2] = dvec3(c);
  auto pass = [&](bool cuts, auto clip, double bound) {
    if (!cuts || count == 0) return;
    count = clip(poly, count, bound, next);
    std::swap(poly, next);
  };
  pass(own.lo.x < box.lo.x, clip_pass<0, true>, double(box.lo.x));
  pass(own.lo.y < box.lo.y, clip_pass<1, true>, double(box.lo.y));
  pass(own.lo.z < box.lo.z, clip_pass<2, true>, double(box.lo.z));
  pass(own.hi.x > box.hi.x, clip_pass<0, false>, double(box.hi.x));
  pass(own.hi.y > box.hi.y, clip_pass<1, false>, double(box.hi.y));
  pass(own.hi.z > box.hi.z, clip_pass<2, false>, double(box.hi.z));
  if (count < 3) return 0.0;
  dvec3 sum(0.0);
  for (int i = 1; i + 1 < count; ++i) sum += glm::cross(poly[i] - poly[0], poly[i + 1] - poly[0]);
  return 0.5 * glm::length(sum);
}

bool overlaps(const Aabb& a, const Aabb& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y &&
         a.lo.z <= b.hi.z && b.lo.z <= a.hi.z;
}

}  // namespace

double sah_cost(const Bvh& bvh, float t1, float t2, const std::vector<float>& weights) {
  if (bvh.nodes.empty()) return 0;
  const size_t count = bvh.nodes.size();
  std::vector<double> cost(count);
  // Children always have larger indices than their parent (validated): one
  // backward pass evaluates the recursion bottom-up.
  for (size_t i = count; i-- > 0;) {
    const BvhNode& n = bvh.nodes[i];
    if (n.is_leaf()) {
      double w = 0;
      for (uint32_t k = n.index; k < n.index + n.count; ++k)
        w += weights.empty() ? 1.0 : double(weights[bvh.prim_refs[k]]);
      cost[i] = double(t2) * w;
      continue;
    }
    const double area = n.bounds.area();
    // One node visit (one TRV op) costs 2*T1 whatever the width.
    cost[i] = 2.0 * t1;
    for (uint32_t c = n.index; c < n.index + n.children; ++c)
      cost[i] += (area > 0 ? bvh.nodes[c].bounds.area() / area : 1.0) * cost[c];
  }
  return cost[0];
}

double two_level_sah_cost(const Bvh& bvh, const Scene& scene, float t1, float t2,
                          const std::vector<float>& weights) {
  if (bvh.nodes.empty()) return 0;
  const double root_area = bvh.root().bounds.area();
  if (!(root_area > 0)) return 0;
  // The unrolled sum from `root` with each node's area as `area_of` gives it.
  const auto unrolled = [&](uint32_t root, const auto& area_of) {
    double sum = 0;
    std::vector<uint32_t> stack{root};
    while (!stack.empty()) {
      const uint32_t i = stack.back();
      stack.pop_back();
      const BvhNode& n = bvh.nodes[i];
      if (bvh.is_instance_leaf(i)) continue;  // its BLAS is summed per placement
      if (!n.is_leaf()) {
        sum += 2.0 * t1 * area_of(n);
        for (uint32_t c = n.index; c < n.index + n.children; ++c) stack.push_back(c);
        continue;
      }
      double w = 0;
      for (uint32_t k = n.index; k < n.index + n.count; ++k)
        w += weights.empty() ? 1.0 : double(weights[bvh.prim_refs[k]]);
      sum += double(t2) * w * area_of(n);
    }
    return sum;
  };
  const double tlas = unrolled(0, [](const BvhNode& n) { return double(n.bounds.area()); });
  // Per instance, its BLAS placed; summed in instance order (deterministic).
  std::vector<double> placed(scene.instances.size(), 0.0);
  tbb::parallel_for(size_t(0), scene.instances.size(), [&](size_t i) {
    const uint32_t root = bvh.blas_roots[scene.instances[i].mesh];
    if (root == Bvh::kNoBlas) return;
    const glm::mat4& m = scene.instances[i].object_to_world;
    placed[i] = unrolled(root, [&](const BvhNode& n) { return double(transformed_box(n.bounds, m).area()); });
  });
  double sum = tlas;
  for (double p : placed) sum += p;
  return sum / root_area;
}

uint64_t count_spatial_splits(const Bvh& bvh) {
  const size_t count = bvh.nodes.size();
  if (count == 0) return 0;
  std::vector<uint32_t> parent(count, ~0u);
  for (size_t i = 0; i < count; ++i) {
    const BvhNode& n = bvh.nodes[i];
    if (!n.is_leaf())
      for (uint32_t c = n.index; c < n.index + n.children; ++c) parent[c] = uint32_t(i);
  }
  // Each triangle's leaves, grouped by triangle.
  std::vector<std::pair<uint32_t, uint32_t>> leaf_of;  // (triangle, leaf)
  leaf_of.reserve(bvh.prim_refs.size());
  for (size_t i = 0; i < count; ++i) {
    const BvhNode& n = bvh.nodes[i];
    if (n.is_leaf())
      for (uint32_t k = n.index; k < n.index + n.count; ++k) leaf_of.push_back({bvh.prim_refs[k], uint32_t(i)});
  }
  std::sort(leaf_of.begin(), leaf_of.end());
  // Walk up from each of a triangle's leaves; a node reached from a second child
  // is where the triangle branched. A walk stops at a node this triangle reached
  // before (the rest of the path is walked already).
  std::vector<uint32_t> stamp(count, ~0u), from(count, 0);
  std::vector<uint8_t> split(count, 0);
  for (size_t i = 0; i < leaf_of.size();) {
    size_t end = i + 1;
    while (end < leaf_of.size() && leaf_of[end].first == leaf_of[i].first) ++end;
    if (end - i > 1) {
      const uint32_t tri = leaf_of[i].first;
      for (size_t k = i; k < end; ++k) {
        uint32_t child = leaf_of[k].second;
        for (uint32_t node = parent[child]; node != ~0u; child = node, node = parent[node]) {
          if (stamp[node] == tri) {
            if (from[node] != child) split[node] = 1;
            break;
          }
          stamp[node] = tri;
          from[node] = child;
        }
      }
    }
    i = end;
  }
  uint64_t splits = 0;
  for (uint8_t s : split) splits += s;
  return splits;
}

double end_point_overlap(const Bvh& bvh, const Scene& scene, float t1, float t2) {
  const size_t n = scene.triangle_count(), count = bvh.nodes.size();
  if (count == 0 || n == 0) return 0;
  // Reference range below every node (depth-first layouts keep it contiguous).
  std::vector<uint32_t> ref_begin(count), ref_end(count);
  for (size_t i = count; i-- > 0;) {
    const BvhNode& node = bvh.nodes[i];
    if (node.is_leaf()) {
      ref_begin[i] = node.index;
      ref_end[i] = node.index + node.count;
    } else {
      ref_begin[i] = ~0u, ref_end[i] = 0;
      for (uint32_t c = node.index; c < node.index + node.children; ++c) {
        ref_begin[i] = std::min(ref_begin[i], ref_begin[c]);
        ref_end[i] = std::max(ref_end[i], ref_end[c]);
      }
    }
  }
  // Where each triangle is referenced (several places only with split references).
  std::vector<uint32_t> first(n + 1, 0), positions(bvh.prim_refs.size());
  for (uint32_t t : bvh.prim_refs) ++first[t + 1];
  for (size_t t = 0; t < n; ++t) first[t + 1] += first[t];
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (uint32_t k = 0; k < bvh.prim_refs.size(); ++k) positions[fill[bvh.prim_refs[k]]++] = k;
  }
  double total_area = 0;
  for (size_t t = 0; t < n; ++t)
    total_area += 0.5 * glm::length(glm::cross(dvec3(scene.vertex(uint32_t(t), 1) - scene.vertex(uint32_t(t), 0)),
                                               dvec3(scene.vertex(uint32_t(t), 2) - scene.vertex(uint32_t(t), 0))));
  if (!(total_area > 0)) return 0;
  // Each triangle's box and its area as clipped_area computes it for a triangle
  // the box does not cut (in double from the double vertices, so bit for bit the
  // same): most triangles met are wholly inside or outside a node's box, and only
  // the ones its planes cut need clipping.
  std::vector<Aabb> tri_box(n);
  std::vector<double> tri_area(n);
  tbb::parallel_for(size_t(0), n, [&](size_t t) {
    const vec3 a = scene.vertex(uint32_t(t), 0), b = scene.vertex(uint32_t(t), 1),
               c = scene.vertex(uint32_t(t), 2);
    tri_box[t] = Aabb::of_triangle(a, b, c);
    tri_area[t] = 0.5 * glm::length(glm::cross(dvec3(b) - dvec3(a), dvec3(c) - dvec3(a)));
  });

  // A subtree whose triangles all lie inside its box, in a tree that references
  // every triangle once, adds all of its area to a node whose box holds its box
  // (and which it is not above): no triangle of it needs visiting. Only the
  // subtrees a node's box cuts are descended.
  bool single_refs = bvh.prim_refs.size() == n;
  for (size_t t = 0; t < n && single_refs; ++t) single_refs = first[t + 1] - first[t] == 1;
  auto contains = [](const Aabb& outer, const Aabb& inner) {
    return inner.lo.x >= outer.lo.x && inner.lo.y >= outer.lo.y && inner.lo.z >= outer.lo.z &&
           inner.hi.x <= outer.hi.x && inner.hi.y <= outer.hi.y && inner.hi.z <= outer.hi.z;
  };
  // In such a tree the triangles are read in reference order, where a leaf's are
  // adjacent (and near its neighbours'), not through the index.
  struct RefTriangle {
    vec3 v[3];
    Aabb box;
    double area;
  };
  std::vector<RefTriangle> ref_triangles(single_refs ? n : 0);
  if (single_refs)
    tbb::parallel_for(size_t(0), n, [&](size_t k) {
      const uint32_t t = bvh.prim_refs[k];
      ref_triangles[k] = RefTriangle{{scene.vertex(t, 0), scene.vertex(t, 1), scene.vertex(t, 2)},
                                     tri_box[t], tri_area[t]};
    });
  std::vector<double> subtree_area(single_refs ? count : 0);
  std::vector<uint8_t> holds_its_triangles(single_refs ? count : 0, 0);
  if (single_refs) {
    for (size_t i = count; i-- > 0;) {
      const BvhNode& node = bvh.nodes[i];
      if (node.is_leaf()) {
        double sum = 0;
        bool inside = true;
        for (uint32_t k = node.index; k < node.index + node.count; ++k) {
          sum += tri_area[bvh.prim_refs[k]];
          inside = inside && contains(node.bounds, tri_box[bvh.prim_refs[k]]);
        }
        subtree_area[i] = sum;
        holds_its_triangles[i] = inside;
      } else {
        double sum = 0;
        bool inside = true;
        for (uint32_t c = node.index; c < node.index + node.children; ++c) {
          sum += subtree_area[c];
          inside = inside && holds_its_triangles[c] && contains(node.bounds, bvh.nodes[c].bounds);
        }
        subtree_area[i] = sum;
        holds_its_triangles[i] = inside;
      }
    }
  }

  struct Scratch {
    std::vector<uint32_t> stamp;
    std::vector<uint32_t> stack;
  };
  tbb::enumerable_thread_specific<Scratch> scratch(
      [n, single_refs] { return Scratch{std::vector<uint32_t>(single_refs ? 0 : n, ~0u), {}}; });
  std::vector<double> contribution(count, 0.0);
  tbb::parallel_for(size_t(1), count, [&](size_t node) {
    Scratch& s = scratch.local();
    const Aabb box = bvh.nodes[node].bounds;
    const uint32_t rb = ref_begin[node], re = ref_end[node];
    double area = 0;
    s.stack.clear();
    s.stack.push_back(0);
    while (!s.stack.empty()) {
      const uint32_t m = s.stack.back();
      s.stack.pop_back();
      if (m == node) continue;  // the node's own subtree
      const BvhNode& other = bvh.nodes[m];
      if (!overlaps(other.bounds, box)) continue;
      if (single_refs && holds_its_triangles[m] && contains(box, other.bounds) &&
          (ref_end[m] <= rb || ref_begin[m] >= re)) {
        area += subtree_area[m];
        continue;
      }
      if (!other.is_leaf()) {
        for (uint32_t c = other.index; c < other.index + other.children; ++c) s.stack.push_back(c);
        continue;
      }
      if (single_refs) {
        // No triangle is met twice and none below the node's range: no stamps.
        for (uint32_t k = other.index; k < other.index + other.count; ++k) {
          const RefTriangle& rt = ref_triangles[k];
          if (!overlaps(rt.box, box)) continue;
          if (contains(box, rt.box))
            area += rt.area;
          else
            area += clipped_area(rt.v[0], rt.v[1], rt.v[2], rt.box, box);
        }
        continue;
      }
      for (uint32_t k = other.index; k < other.index + other.count; ++k) {
        const uint32_t t = bvh.prim_refs[k];
        if (s.stamp[t] == uint32_t(node)) continue;
        s.stamp[t] = uint32_t(node);
        bool below = false;
        for (uint32_t p = first[t]; p < first[t + 1] && !below; ++p)
          below = positions[p] >= rb && positions[p] < re;
        if (below) continue;
        const Aabb& tb = tri_box[t];
        if (!overlaps(tb, box)) continue;  // every vertex outside one plane: area 0
        if (tb.lo.x >= box.lo.x && tb.lo.y >= box.lo.y && tb.lo.z >= box.lo.z &&
            tb.hi.x <= box.hi.x && tb.hi.y <= box.hi.y && tb.hi.z <= box.hi.z)
          area += tri_area[t];  // wholly inside: no plane clips it
        else
          area += clipped_area(scene.vertex(t, 0), scene.vertex(t, 1), scene.vertex(t, 2), tb, box);
      }
    }
    const BvhNode& self = bvh.nodes[node];
    const double c = self.is_leaf() ? double(t2) * self.count : 2.0 * double(t1);
    contribution[node] = c * area;
  });
  double sum = 0;
  for (double c : contribution) sum += c;  // fixed order: deterministic
  return sum / total_area;
}

BvhMetrics compute_metrics(const Bvh& bvh, const Scene& scene, const BuildParams& params,
                           const BuildReport& report, bool with_epo) {
  const auto start = std::chrono::steady_clock::now();
  BvhMetrics m;
  m.builder = report.builder.empty() ? params.builder : report.builder;
  m.triangles = scene.triangle_count();
  m.references = bvh.prim_refs.size();
  m.nodes = bvh.nodes.size();
  m.width = bvh.width();
  // Depths: a forward pass, parents come before children (a BLAS root: depth 0).
  std::vector<uint32_t> depth(bvh.nodes.size(), 0);
  for (size_t i = 0; i < bvh.nodes.size(); ++i) {
    const BvhNode& n = bvh.nodes[i];
    if (n.is_leaf()) {
      if (bvh.is_instance_leaf(uint32_t(i))) continue;
      ++m.leaves;
      if (m.leaf_size_histogram.size() <= n.count) m.leaf_size_histogram.resize(n.count + 1, 0);
      ++m.leaf_size_histogram[n.count];
    } else {
      ++m.inner_nodes;
      for (uint32_t c = n.index; c < n.index + n.children; ++c) depth[c] = depth[i] + 1;
    }
  }
  double depth_sum = 0;
  uint64_t depth_leaves = 0;
  if (!bvh.two_level()) {
    m.sah_cost = sah_cost(bvh, params.t1, params.t2);
    m.weighted_cost = sah_cost(bvh, params.t1, params.t2, report.weights);
    if (with_epo) m.epo = end_point_overlap(bvh, scene, params.t1, params.t2);
    for (size_t i = 0; i < bvh.nodes.size(); ++i)
      if (bvh.nodes[i].is_leaf()) m.max_depth = std::max(m.max_depth, depth[i]), depth_sum += depth[i], ++depth_leaves;
  } else {
    m.sah_cost = two_level_sah_cost(bvh, scene, params.t1, params.t2);
    m.weighted_cost = two_level_sah_cost(bvh, scene, params.t1, params.t2, report.weights);
    m.tlas_nodes = bvh.tlas_nodes;
    m.references = 0;
    for (size_t i = bvh.tlas_nodes; i < bvh.nodes.size(); ++i)
      if (bvh.nodes[i].is_leaf()) m.references += bvh.nodes[i].count;
    // Each BLAS's leaf depths once (sum, count, deepest), then per placement.
    struct LeafDepths {
      double sum = 0;
      uint64_t count = 0;
      uint32_t deepest = 0;
    };
    std::vector<LeafDepths> blas(bvh.blas_roots.size());
    std::vector<uint32_t> mesh_of(bvh.nodes.size(), ~0u);
    for (uint32_t mesh = 0; mesh < bvh.blas_roots.size(); ++mesh)
      if (bvh.blas_roots[mesh] != Bvh::kNoBlas) mesh_of[bvh.blas_roots[mesh]] = mesh;
    for (size_t i = bvh.tlas_nodes; i < bvh.nodes.size(); ++i) {
      const BvhNode& n = bvh.nodes[i];
      if (n.is_leaf()) {
        LeafDepths& d = blas[mesh_of[i]];
        d.sum += depth[i], ++d.count, d.deepest = std::max(d.deepest, depth[i]);
      } else {
        for (uint32_t c = n.index; c < n.index + n.children; ++c) mesh_of[c] = mesh_of[i];
      }
    }
    for (uint32_t i = 0; i < bvh.tlas_nodes; ++i) {
      if (!bvh.is_instance_leaf(i)) continue;
      const uint32_t instance = bvh.prim_refs[bvh.nodes[i].index];
      const uint32_t mesh = scene.instances[instance].mesh;
      const LeafDepths& d = blas[mesh];
      ++m.instances;
      m.placed_triangles += scene.meshes[mesh].triangle_count;
      // The instance leaf, then one step into its BLAS root.
      m.max_depth = std::max(m.max_depth, depth[i] + 1 + d.deepest);
      depth_sum += d.sum + double(depth[i] + 1) * double(d.count);
      depth_leaves += d.count;
    }
  }
  m.average_leaf_depth = depth_leaves ? depth_sum / double(depth_leaves) : 0;
  m.estimate_seconds = report.estimate_seconds;
  m.build_seconds = report.build_seconds;
  m.peak_memory_bytes = report.peak_memory_bytes;
  m.spatial_splits = report.spatial_splits;
  m.treelets_restructured = report.treelets_restructured;
  m.forced_splits = report.forced_splits;
  m.median_splits = report.median_splits;
  m.sanitised_values = report.sanitised_values;
  m.metrics_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return m;
}

std::string metrics_json(const BvhMetrics& m) {
  nlohmann::json j;
  j["builder"] = m.builder;
  j["sah_cost"] = m.sah_cost;
  j["weighted_cost"] = m.weighted_cost;
  if (m.epo >= 0) j["epo"] = m.epo;
  j["width"] = m.width;
  j["nodes"] = m.nodes;
  j["inner_nodes"] = m.inner_nodes;
  j["leaves"] = m.leaves;
  j["references"] = m.references;
  j["triangles"] = m.triangles;
  j["leaf_size_histogram"] = m.leaf_size_histogram;
  j["max_depth"] = m.max_depth;
  j["average_leaf_depth"] = m.average_leaf_depth;
  j["estimate_seconds"] = m.estimate_seconds;
  j["build_seconds"] = m.build_seconds;
  j["metrics_seconds"] = m.metrics_seconds;
  j["peak_memory_bytes"] = m.peak_memory_bytes;
  j["peak_memory_bytes_per_triangle"] =
      m.triangles ? double(m.peak_memory_bytes) / double(m.triangles) : 0.0;
  j["spatial_splits"] = m.spatial_splits;
  j["treelets_restructured"] = m.treelets_restructured;
  j["forced_splits"] = m.forced_splits;
  j["median_splits"] = m.median_splits;
  j["sanitised_values"] = m.sanitised_values;
  if (m.instances) {
    j["instances"] = m.instances;
    j["tlas_nodes"] = m.tlas_nodes;
    j["placed_triangles"] = m.placed_triangles;
  }
  return j.dump();
}

}  // namespace rtsim
