#pragma once
// Versioned binary ray file, so the same rays can be replayed through the timing
// model and across builders.
//
// Layout (little endian):
//   header  magic "RTSIMRAY" (8 B), version u32 (= 1), record_bytes u32 (= 48),
//           ray count u64, scene content hash u64 (0 = unknown)
//   records origin 3 x f32, tmin f32, direction 3 x f32, tmax f32, type u8,
//           bounce u8, reserved u16 (0), pixel u32, sample u32, parent u32
#include <rtsim/model/core/ray.h>

#include <cstdint>
#include <filesystem>
#include <vector>

namespace rtsim {

constexpr uint32_t kRayFileVersion = 1;
constexpr uint32_t kRayRecordBytes = 48;

struct RaySet {
  std::vector<Ray> rays;
  uint64_t scene_hash = 0;
};

// Written atomically (temp + rename).
void write_ray_file(const std::filesystem::path& path, const RaySet& set);
// Throws InputError naming the file and the field/offset for a bad magic, an
// unknown version, a short file, a bad ray type or a non-finite value in a ray.
RaySet read_ray_file(const std::filesystem::path& path);

}  // namespace rtsim
