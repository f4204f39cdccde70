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
//   nodes    per node: 6 x f32 box (lo xyz, hi xyz), u32 index, u32 count,
//            u32 children (version 2; version 1 files, binary trees, lack it)
//   refs     u32 triangle index each
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

constexpr uint32_t kBvhFileVersion = 2;

struct BvhFileHeader {
  uint32_t version = kBvhFileVersion;
  uint64_t scene_hash = 0;
  uint64_t triangle_count = 0;
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
