#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/random.h>

#include <algorithm>

namespace rtsim {

uint64_t bvh_content_hash(const Bvh& bvh) {
  uint64_t h = hash_bytes(0x425648ull, bvh.prim_refs.data(), bvh.prim_refs.size() * sizeof(uint32_t));
  for (const BvhNode& n : bvh.nodes) {
    const float box[6] = {n.bounds.lo.x, n.bounds.lo.y, n.bounds.lo.z, n.bounds.hi.x, n.bounds.hi.y, n.bounds.hi.z};
    h = hash_bytes(h, box, sizeof box);
    const uint32_t links[2] = {n.index, n.count};
    h = hash_bytes(h, links, sizeof links);
    // Binary trees keep the names they had before trees could be wide.
    if (n.children > 2) h = hash_bytes(h, &n.children, sizeof n.children);
  }
  // One-level trees keep their names: only a two-level tree hashes its levels.
  if (bvh.two_level()) {
    h = hash_bytes(h, &bvh.tlas_nodes, sizeof bvh.tlas_nodes);
    h = hash_bytes(h, bvh.blas_roots.data(), bvh.blas_roots.size() * sizeof(uint32_t));
  }
  return h;
}

uint32_t Bvh::width() const {
  uint32_t w = 2;
  for (const BvhNode& n : nodes) w = std::max(w, n.children);
  return w;
}

}  // namespace rtsim
