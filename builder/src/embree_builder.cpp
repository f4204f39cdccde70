// The reference builders: Embree's own rtcBuildBVH, with its costs set to ours
// (traversalCost = 2*T1: the cost of one node visit, one TRV op, whatever the
// width; intersectionCost = T2) and its output converted into our flat Bvh.
// With maxBranchingFactor 4 or 8 it is Embree's own wide builder: the reference
// for the collapse pass.
#include "embree_builder.h"
#include "triangle_clip.h"

#include <rtsim/workloads/error.h>

#include <embree3/rtcore.h>
#include <embree3/rtcore_builder.h>

#include <algorithm>
#include <atomic>
#include <map>
#include <mutex>
#include <new>
#include <stdexcept>
#include <string>

namespace rtsim::detail {

namespace {

// Embree's builder calls these back for every node it makes, so their cost is part
// of the yardstick: a node is as small as its kind and width allow. An inner node's
// child pointers and boxes follow it in the same allocation, a leaf's primitive list
// likewise.
struct alignas(alignof(void*)) EmbreeNode {
  uint32_t children = 0;  // inner nodes
  bool leaf = false;
  uint32_t count = 0;  // leaves: primitives, the list after the node
  Aabb leaf_box;
  const EmbreeNode** child() { return reinterpret_cast<const EmbreeNode**>(this + 1); }
  const EmbreeNode* const* child() const { return reinterpret_cast<const EmbreeNode* const*>(this + 1); }
  Aabb* child_box() { return reinterpret_cast<Aabb*>(child() + children); }
  const Aabb* child_box() const { return reinterpret_cast<const Aabb*>(child() + children); }
  const uint32_t* prims() const { return reinterpret_cast<const uint32_t*>(this + 1); }
};
static_assert(sizeof(EmbreeNode) % alignof(const EmbreeNode*) == 0, "child pointers follow the node");

struct Context {
  const Scene* scene;
  std::atomic<uint64_t> bytes{0};
};

void* create_node(RTCThreadLocalAllocator alloc, unsigned int child_count, void* user) {
  auto* ctx = static_cast<Context*>(user);
  const uint32_t children = std::min<unsigned>(child_count, kMaxBvhWidth);  // <= maxBranchingFactor
  const size_t bytes = sizeof(EmbreeNode) + children * (sizeof(EmbreeNode*) + sizeof(Aabb));
  ctx->bytes.fetch_add(bytes, std::memory_order_relaxed);
  auto* node = new (rtcThreadLocalAlloc(alloc, bytes, 16)) EmbreeNode();
  node->children = children;
  for (uint32_t c = 0; c < children; ++c) {
    new (node->child() + c) const EmbreeNode*(nullptr);
    new (node->child_box() + c) Aabb();
  }
  return node;
}

void set_children(void* node_ptr, void** children, unsigned int child_count, void*) {
  auto* node = static_cast<EmbreeNode*>(node_ptr);
  for (unsigned i = 0; i < child_count && i < node->children; ++i)
    node->child()[i] = static_cast<const EmbreeNode*>(children[i]);
}

void set_bounds(void* node_ptr, const RTCBounds** bounds, unsigned int child_count, void*) {
  auto* node = static_cast<EmbreeNode*>(node_ptr);
  for (unsigned i = 0; i < child_count && i < node->children; ++i)
    node->child_box()[i] = Aabb{vec3(bounds[i]->lower_x, bounds[i]->lower_y, bounds[i]->lower_z),
                                vec3(bounds[i]->upper_x, bounds[i]->upper_y, bounds[i]->upper_z)};
}

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count,
                  void* user) {
  auto* ctx = static_cast<Context*>(user);
  const size_t bytes = sizeof(EmbreeNode) + count * sizeof(uint32_t);
  ctx->bytes.fetch_add(bytes, std::memory_order_relaxed);
  auto* node = new (rtcThreadLocalAlloc(alloc, bytes, 16)) EmbreeNode();
  auto* list = reinterpret_cast<uint32_t*>(node + 1);
  node->leaf = true;
  node->count = uint32_t(count);
  for (size_t i = 0; i < count; ++i) {
    list[i] = prims[i].primID;
    node->leaf_box.extend(Aabb{vec3(prims[i].lower_x, prims[i].lower_y, prims[i].lower_z),
                               vec3(prims[i].upper_x, prims[i].upper_y, prims[i].upper_z)});
  }
  return node;
}

// Clips the real triangle at the plane (SBVH-style), bounded by the primitive's box.
void split_primitive(const RTCBuildPrimitive* prim, unsigned int dim, float pos,
                     RTCBounds* left_out, RTCBounds* right_out, void* user) {
  const Scene& scene = *static_cast<Context*>(user)->scene;
  const int axis = int(dim);
  const vec3 v[3] = {scene.vertex(prim->primID, 0), scene.vertex(prim->primID, 1),
                     scene.vertex(prim->primID, 2)};
  const Aabb box{vec3(prim->lower_x, prim->lower_y, prim->lower_z),
                 vec3(prim->upper_x, prim->upper_y, prim->upper_z)};
  Aabb left, right;
  clip_triangle(v, axis, pos, box, &left, &right);
  // Embree expects valid boxes on both sides: an empty side becomes the flat slice
  // of the primitive's box at the plane.
  auto flat_slice = [&] {
    Aabb slice = box;
    slice.lo[axis] = slice.hi[axis] = std::min(std::max(pos, box.lo[axis]), box.hi[axis]);
    return slice;
  };
  if (left.empty()) left = flat_slice();
  if (right.empty()) right = flat_slice();
  *left_out = RTCBounds{left.lo.x, left.lo.y, left.lo.z, 0, left.hi.x, left.hi.y, left.hi.z, 0};
  *right_out = RTCBounds{right.lo.x, right.lo.y, right.lo.z, 0, right.hi.x, right.hi.y, right.hi.z, 0};
}

// One Embree device per thread count: the device owns the builder's thread pool.
RTCDevice device_for_threads(uint32_t threads) {
  static std::mutex mutex;
  static std::map<uint32_t, RTCDevice> devices;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = devices.find(threads);
  if (it != devices.end()) return it->second;
  const std::string config = threads ? "threads=" + std::to_string(threads) : "";
  RTCDevice device = rtcNewDevice(config.c_str());
  if (!device) throw std::runtime_error("Embree: cannot create a device");
  devices[threads] = device;
  return device;
}

}  // namespace

Bvh build_with_embree(const Scene& scene, const EmbreeBuildConfig& config,
                      EmbreeBuildStats* stats) {
  const size_t n = scene.triangle_count();
  if (n == 0) throw InputError("scene '" + scene.name + "'", "has no triangles to build a BVH over");
  if (config.max_leaf_size == 0 || config.max_leaf_size > RTC_BUILD_MAX_PRIMITIVES_PER_LEAF)
    throw InputError("max_leaf_size", "Embree builders accept 1.." +
                                          std::to_string(RTC_BUILD_MAX_PRIMITIVES_PER_LEAF));
  RTCDevice device = device_for_threads(config.threads);
  const size_t capacity =
      config.spatial_splits ? std::max<size_t>(n, size_t(double(n) * config.capacity_factor)) : n;
  std::vector<RTCBuildPrimitive> prims(capacity);
  for (size_t i = 0; i < n; ++i) {
    const Aabb box = scene.triangle_bounds(uint32_t(i));
    prims[i] = RTCBuildPrimitive{box.lo.x, box.lo.y, box.lo.z, 0u,
                                 box.hi.x, box.hi.y, box.hi.z, uint32_t(i)};
  }
  Context ctx;
  ctx.scene = &scene;
  RTCBVH handle = rtcNewBVH(device);
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.buildQuality = config.spatial_splits ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM;
  args.maxBranchingFactor = config.width;
  args.maxDepth = config.max_depth;
  args.sahBlockSize = 1;
  args.minLeafSize = 1;
  args.maxLeafSize = config.max_leaf_size;
  args.traversalCost = 2.0f * config.t1;
  args.intersectionCost = config.t2;
  args.bvh = handle;
  args.primitives = prims.data();
  args.primitiveCount = n;
  args.primitiveArrayCapacity = capacity;
  args.createNode = create_node;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_bounds;
  args.createLeaf = create_leaf;
  args.splitPrimitive = config.spatial_splits ? split_primitive : nullptr;
  args.userPtr = &ctx;
  const auto* root = static_cast<const EmbreeNode*>(rtcBuildBVH(&args));
  if (!root || rtcGetDeviceError(device) != RTC_ERROR_NONE) {
    rtcReleaseBVH(handle);
    throw std::runtime_error("Embree rtcBuildBVH failed");
  }

  // Depth-first conversion, children adjacent; split references of one triangle
  // that meet in one leaf are listed once.
  Bvh bvh;
  bvh.nodes.reserve(2 * n);
  bvh.prim_refs.reserve(n);
  Aabb root_box = root->leaf_box;
  if (!root->leaf)
    for (uint32_t c = 0; c < root->children; ++c) root_box.extend(root->child_box()[c]);
  bvh.nodes.push_back(BvhNode{root_box, 0, 0});
  std::vector<std::pair<const EmbreeNode*, uint32_t>> stack{{root, 0u}};
  std::vector<uint32_t> list;
  while (!stack.empty()) {
    const auto [node, index] = stack.back();
    stack.pop_back();
    if (node->leaf) {
      list.assign(node->prims(), node->prims() + node->count);
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
      bvh.nodes[index].index = uint32_t(bvh.prim_refs.size());
      bvh.nodes[index].count = uint32_t(list.size());
      bvh.prim_refs.insert(bvh.prim_refs.end(), list.begin(), list.end());
      continue;
    }
    const uint32_t first = uint32_t(bvh.nodes.size());
    bvh.nodes[index].index = first;
    bvh.nodes[index].count = 0;
    bvh.nodes[index].children = node->children;
    for (uint32_t c = 0; c < node->children; ++c)
      bvh.nodes.push_back(BvhNode{node->child_box()[c], 0, 0, 0});
    for (uint32_t c = node->children; c-- > 0;) stack.push_back({node->child()[c], first + c});
  }
  if (stats)
    stats->working_bytes = capacity * sizeof(RTCBuildPrimitive) + ctx.bytes.load() +
                           bvh.nodes.capacity() * sizeof(BvhNode) +
                           bvh.prim_refs.capacity() * sizeof(uint32_t);
  rtcReleaseBVH(handle);
  return bvh;
}

}  // namespace rtsim::detail
