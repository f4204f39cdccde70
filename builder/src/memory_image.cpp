#include <rtsim/builder/memory_image.h>

#include <cstdio>

namespace rtsim {

namespace {
uint64_t align_up(uint64_t value, uint64_t alignment) {
  return alignment == 0 ? value : (value + alignment - 1) / alignment * alignment;
}
}  // namespace

MemoryImage::MemoryImage(const Bvh& bvh, size_t scene_triangle_count,
                         const MemoryLayoutConfig& config)
    : config_(config),
      node_bytes_(config.node_layout == NodeLayout::Bvh2Wide64 ? 64u : 32u) {
  nodes_base_ = align_up(config_.base_address, config_.region_alignment);
  prim_refs_base_ = align_up(nodes_base_ + uint64_t(bvh.nodes.size()) * node_bytes_,
                             config_.region_alignment);
  triangles_base_ = align_up(prim_refs_base_ + uint64_t(bvh.prim_refs.size()) * 4,
                             config_.region_alignment);
  end_ = triangles_base_ + uint64_t(scene_triangle_count) * config_.triangle_bytes;
}

std::string MemoryImage::describe() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "nodes      0x%010llx  %llu B (%u B/node)\n"
                "prim_refs  0x%010llx  %llu B\n"
                "triangles  0x%010llx  %llu B (%u B/triangle)\n",
                (unsigned long long)nodes_base_,
                (unsigned long long)(prim_refs_base_ - nodes_base_), node_bytes_,
                (unsigned long long)prim_refs_base_,
                (unsigned long long)(triangles_base_ - prim_refs_base_),
                (unsigned long long)triangles_base_, (unsigned long long)(end_ - triangles_base_),
                config_.triangle_bytes);
  return buf;
}

}  // namespace rtsim
