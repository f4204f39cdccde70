// BVH files through load_bvh, with and without a scene. The trailing checksum
// would stop almost every mutation at the first check, so the harness rewrites
// it (same function as builder/src/bvh_file.cpp) and, for the call with a scene,
// also writes that scene's hash and triangle count into the header: the
// mutations then reach the node, reference and tree checks. A third call does the
// same for an instanced scene (its instance count too, in version 3 files), so
// that two-level trees (seed two-level.bvh) reach the TLAS and BLAS checks.
#include "fuzz_support.h"

#include <rtsim/builder/bvh_file.h>
#include <rtsim/workloads/random.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cstring>

namespace {
uint64_t bvh_checksum(const uint8_t* data, size_t size) {
  uint64_t h = 0x4256'4846'494C'4531ull;
  size_t i = 0;
  for (; i + 8 <= size; i += 8) {
    uint64_t w;
    std::memcpy(&w, data + i, 8);
    h = rtsim::mix64(h ^ w);
  }
  uint64_t tail = 0;
  std::memcpy(&tail, data + i, size - i);
  return rtsim::mix64(h ^ tail ^ (uint64_t(size) << 40));
}

void fix_checksum(std::vector<uint8_t>& bytes) {
  if (bytes.size() < 16) return;
  const uint64_t sum = bvh_checksum(bytes.data(), bytes.size() - 8);
  std::memcpy(bytes.data() + bytes.size() - 8, &sum, 8);
}

const rtsim::Scene& fuzz_scene() {
  static const rtsim::Scene scene = [] {
    rtsim::Scene s;
    s.name = "fuzz";
    s.materials.push_back(rtsim::Material{});
    for (int i = 0; i < 8; ++i) {
      const rtsim::vec3 p(float(i), 0.0f, 0.0f);
      const uint32_t base = uint32_t(s.vertices.size());
      s.vertices.insert(s.vertices.end(), {p, p + rtsim::vec3(1, 0, 0), p + rtsim::vec3(0, 1, 0)});
      s.triangles.push_back(rtsim::uvec3(base, base + 1, base + 2));
      s.material_ids.push_back(0);
    }
    return s;
  }();
  return scene;
}
// The same eight triangles as two meshes (5 and 3), placed three times.
const rtsim::Scene& fuzz_instanced_scene() {
  static const rtsim::Scene scene = [] {
    rtsim::Scene s = fuzz_scene();
    s.name = "fuzz_instanced";
    s.meshes.resize(2);
    s.meshes[0].name = "a", s.meshes[0].vertex_count = 15, s.meshes[0].triangle_count = 5;
    s.meshes[1].name = "b", s.meshes[1].first_vertex = 15, s.meshes[1].vertex_count = 9;
    s.meshes[1].first_triangle = 5, s.meshes[1].triangle_count = 3;
    s.instances.resize(3);
    s.instances[1].object_to_world = glm::translate(glm::mat4(1.0f), rtsim::vec3(0, 3, 0));
    s.instances[2].mesh = 1;
    s.instances[2].object_to_world =
        glm::scale(glm::translate(glm::mat4(1.0f), rtsim::vec3(0, 0, 2)), rtsim::vec3(2.0f));
    return s;
  }();
  return scene;
}

// Writes `scene`'s hash and triangle count into the header (and, in a version 3
// file whose texts are in bounds, its instance count), with the checksum after.
void claim_for(std::vector<uint8_t>& bytes, const rtsim::Scene& scene) {
  const uint64_t hash = scene.content_hash(), count = scene.triangle_count();
  std::memcpy(bytes.data() + 12, &hash, 8);
  std::memcpy(bytes.data() + 20, &count, 8);
  uint32_t version;
  std::memcpy(&version, bytes.data() + 8, 4);
  size_t at = 28;  // the builder's name, then the parameters: u32 length + bytes each
  for (int text = 0; text < 2; ++text) {
    uint32_t length;
    if (at + 4 > bytes.size()) return fix_checksum(bytes);
    std::memcpy(&length, bytes.data() + at, 4);
    at += 4 + size_t(length);
  }
  at += 16 + 4;  // node and reference counts, TLAS node count
  if (version == 3 && at + 8 <= bytes.size()) {
    const uint64_t instances = scene.instances.size();
    std::memcpy(bytes.data() + at, &instances, 8);
  }
  fix_checksum(bytes);
}
}  // namespace

RTSIM_FUZZ_TARGET(bvh_file) {
  using namespace rtsim::fuzz;
  const std::filesystem::path file = scratch_dir() / "fuzz.bvh";
  std::vector<uint8_t> bytes(data, data + size);
  fix_checksum(bytes);
  write_bytes(file, bytes.data(), bytes.size());
  expect_only_input_errors([&] { rtsim::load_bvh(file); });
  if (bytes.size() >= 36) {  // magic 8, version 4, scene hash 8 at 12, triangle count 8 at 20
    for (const rtsim::Scene* scene : {&fuzz_scene(), &fuzz_instanced_scene()}) {
      claim_for(bytes, *scene);
      write_bytes(file, bytes.data(), bytes.size());
      expect_only_input_errors([&] { rtsim::load_bvh(file, scene); });
    }
  }
  return 0;
}
