#include <rtsim/model/core/ray_file.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <string>

namespace rtsim {

namespace {
constexpr char kMagic[8] = {'R', 'T', 'S', 'I', 'M', 'R', 'A', 'Y'};
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8 + 8;

// Little-endian helpers (the file format is LE whatever the host).
void put_u32(unsigned char* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i));
}
void put_u64(unsigned char* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i));
}
void put_f32(unsigned char* p, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  put_u32(p, v);
}
uint32_t get_u32(const unsigned char* p) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(p[i]) << (8 * i);
  return v;
}
uint64_t get_u64(const unsigned char* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t(p[i]) << (8 * i);
  return v;
}
float get_f32(const unsigned char* p) {
  const uint32_t v = get_u32(p);
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}
}  // namespace

void write_ray_file(const std::filesystem::path& path, const RaySet& set) {
  write_file_atomic(path, [&](std::ostream& out) {
    unsigned char header[kHeaderBytes];
    std::memcpy(header, kMagic, 8);
    put_u32(header + 8, kRayFileVersion);
    put_u32(header + 12, kRayRecordBytes);
    put_u64(header + 16, set.rays.size());
    put_u64(header + 24, set.scene_hash);
    out.write(reinterpret_cast<const char*>(header), kHeaderBytes);
    std::vector<unsigned char> buffer;
    constexpr size_t kChunk = 4096;
    for (size_t first = 0; first < set.rays.size(); first += kChunk) {
      const size_t n = std::min(kChunk, set.rays.size() - first);
      buffer.assign(n * kRayRecordBytes, 0);
      for (size_t i = 0; i < n; ++i) {
        const Ray& r = set.rays[first + i];
        unsigned char* p = buffer.data() + i * kRayRecordBytes;
        put_f32(p + 0, r.origin.x);
        put_f32(p + 4, r.origin.y);
        put_f32(p + 8, r.origin.z);
        put_f32(p + 12, r.tmin);
        put_f32(p + 16, r.direction.x);
        put_f32(p + 20, r.direction.y);
        put_f32(p + 24, r.direction.z);
        put_f32(p + 28, r.tmax);
        p[32] = uint8_t(r.type);
        p[33] = r.bounce;
        put_u32(p + 36, r.pixel);
        put_u32(p + 40, r.sample);
        put_u32(p + 44, r.parent);
      }
      out.write(reinterpret_cast<const char*>(buffer.data()), std::streamsize(buffer.size()));
    }
  });
}

RaySet read_ray_file(const std::filesystem::path& path) {
  const std::string name = path.string();
  check_input_file(path, kMaxDataFileBytes);  // a regular file of bounded size: no FIFO, no device
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(name, "cannot open the ray file");
  in.seekg(0, std::ios::end);
  const uint64_t file_size = uint64_t(in.tellg());
  in.seekg(0);
  unsigned char header[kHeaderBytes];
  if (file_size < kHeaderBytes || !in.read(reinterpret_cast<char*>(header), kHeaderBytes))
    throw InputError(name, "header: truncated (" + std::to_string(file_size) + " bytes, need " +
                               std::to_string(kHeaderBytes) + ")");
  if (std::memcmp(header, kMagic, 8) != 0)
    throw InputError(name, "offset 0: magic: not a rtsim ray file");
  const uint32_t version = get_u32(header + 8);
  if (version != kRayFileVersion)
    throw InputError(name, "offset 8: version: " + std::to_string(version) + " is not supported (this rtsim reads " +
                               std::to_string(kRayFileVersion) + ")");
  const uint32_t record_bytes = get_u32(header + 12);
  if (record_bytes != kRayRecordBytes)
    throw InputError(name, "offset 12: record_bytes: " + std::to_string(record_bytes) + ", expected " +
                               std::to_string(kRayRecordBytes));
  const uint64_t count = get_u64(header + 16);
  const uint64_t payload = file_size - kHeaderBytes;
  if (count > payload / kRayRecordBytes || payload != count * kRayRecordBytes)
    throw InputError(name, "offset 16: ray count " + std::to_string(count) + " needs " +
                               std::to_string(count) + " x " + std::to_string(kRayRecordBytes) +
                               " bytes of records, the file has " + std::to_string(payload) +
                               " (truncated or padded)");
  RaySet set;
  set.scene_hash = get_u64(header + 24);
  set.rays.resize(count);
  std::vector<unsigned char> buffer;
  constexpr size_t kChunk = 4096;
  for (uint64_t first = 0; first < count; first += kChunk) {
    const size_t n = size_t(std::min<uint64_t>(kChunk, count - first));
    buffer.resize(n * kRayRecordBytes);
    if (!in.read(reinterpret_cast<char*>(buffer.data()), std::streamsize(buffer.size())))
      throw InputError(name, "offset " + std::to_string(kHeaderBytes + first * kRayRecordBytes) +
                                 ": read failed");
    for (size_t i = 0; i < n; ++i) {
      const unsigned char* p = buffer.data() + i * kRayRecordBytes;
      const uint64_t offset = kHeaderBytes + (first + i) * kRayRecordBytes;
      auto where = [&](const char* field, size_t at) {
        return name + ": offset " + std::to_string(offset + at) + ": ray " +
               std::to_string(first + i) + " " + field;
      };
      Ray& r = set.rays[first + i];
      r.origin = {get_f32(p + 0), get_f32(p + 4), get_f32(p + 8)};
      r.tmin = get_f32(p + 12);
      r.direction = {get_f32(p + 16), get_f32(p + 20), get_f32(p + 24)};
      r.tmax = get_f32(p + 28);
      if (!is_finite(r.origin)) throw InputError(where("origin", 0), "not finite");
      if (!std::isfinite(r.tmin)) throw InputError(where("tmin", 12), "not finite");
      if (!is_finite(r.direction) || r.direction == vec3(0.0f))
        throw InputError(where("direction", 16), "not finite or zero");
      if (std::isnan(r.tmax) || r.tmax < r.tmin)
        throw InputError(where("tmax", 28), "NaN or below tmin");
      if (p[32] >= kRayTypeCount)
        throw InputError(where("type", 32), "unknown ray type " + std::to_string(p[32]));
      r.type = RayType(p[32]);
      r.bounce = p[33];
      r.pixel = get_u32(p + 36);
      r.sample = get_u32(p + 40);
      r.parent = get_u32(p + 44);
      if (r.parent != kNoParent && r.parent >= first + i)
        throw InputError(where("parent", 44), "must name an earlier ray");
    }
  }
  return set;
}

}  // namespace rtsim
