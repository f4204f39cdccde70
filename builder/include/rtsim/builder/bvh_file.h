#pragma once
// BVH files: a versioned binary format that `rtsim` writes and loads again.
//
// Layout (little-endian):
//   char[8]  magic "RTSIMBVH"
//   u32      version (kBvhFileVersion)
//   u64      scene content hash (Scene::content_hash())
//   u64      scene triangle count
//   u32 + n  builder name
//   u32 + n  build parameters (JSON text)
//   u64      node count, u64 reference count
//   version 3 on: the two levels (Bvh::two_level; zeros for a one-level tree)
//     u32    TLAS node count, u64 instance count, u64 mesh count,
//     u32    BLAS root per mesh (Bvh::kNoBlas: a mesh without triangles)
//   nodes    per node: 6 x f32 box (lo xyz, hi xyz), u32 index, u32 count,
//            u32 children (version 2 on; version 1 files, binary trees, lack it)
//   refs     u32 each: a triangle index (a TLAS leaf's: an instance index)
//   u64      checksum of every byte before it
// A corrupt, truncated or mismatched file is refused with an InputError naming the
// file and the field ("tree.bvh: header.scene_hash: ...").
#include <rtsim/builder/build.h>
#include <rtsim/builder/bvh.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <filesystem>
#include <string>

namespace rtsim {

constexpr uint32_t kBvhFileVersion = 3;

struct BvhFileHeader {
  uint32_t version = kBvhFileVersion;
  uint64_t scene_hash = 0;
  uint64_t triangle_count = 0;
  uint64_t instance_count = 0;  // version 3: the scene's instances (0: a flat scene)
  std::string builder;
  std::string params_json;
};

std::string build_params_json(const BuildParams& params);  // the parameters that shape the tree

// Writes atomically (temp file + rename).
void save_bvh(const std::filesystem::path& path, const Bvh& bvh, const Scene& scene,
              const BuildParams& params);
void save_bvh(const std::filesystem::path& path, const Bvh& bvh, const BvhFileHeader& header);

// With `scene`, the file must belong to it (hash and triangle count) and the tree
// must pass the structural checks that need no limits (indices in range, every
// triangle reachable).
Bvh load_bvh(const std::filesystem::path& path, const Scene* scene = nullptr,
             BvhFileHeader* header = nullptr);

}  // namespace rtsim
