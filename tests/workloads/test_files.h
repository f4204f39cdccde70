#pragma once
// What the workloads tests share: files they write, a fresh folder per test and name, and whole
// files of bytes or text (their folders made on the way).
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/random.h>
#include <rtsim/workloads/scene.h>

#include <gtest/gtest.h>

#include <initializer_list>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace rtsim::test {

// An empty folder under the system's temp folder, named by the test file's prefix,
// the name and the run's random seed (parallel runs do not share it).
inline std::filesystem::path temp_dir(const std::string& prefix, const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      (prefix + name + "_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// Appends the bytes of `value` as the host stores them (little-endian here), as the
// binary formats' readers take them.
template <typename T>
void put(std::vector<uint8_t>& out, T value) {
  const auto* p = reinterpret_cast<const uint8_t*>(&value);
  out.insert(out.end(), p, p + sizeof(T));
}

inline void write_bytes(const std::filesystem::path& path, const std::vector<uint8_t>& bytes) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path) << text;
}

// Expects `f` to throw an InputError whose message contains every fragment.
template <typename F>
void expect_input_error(F&& f, std::initializer_list<std::string> fragments) {
  try {
    f();
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    for (const std::string& fragment : fragments)
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
          << "message '" << e.what() << "' lacks '" << fragment << "'";
  }
}

// A hash of a flat mesh's (Mesh's or Scene's) geometry, materials and texture
// coordinates, bit for bit: pins a loader's output to what it was.
template <typename M>
uint64_t geometry_hash(const M& m) {
  uint64_t h = 0x4D45'5348ull;
  const auto add = [&h](const auto& v) {  // an empty vector's data() may be null: memcpy must not see it
    h = hash_bytes(h, &h, 0);
    if (!v.empty()) h = hash_bytes(h, v.data(), v.size() * sizeof(v[0]));
  };
  add(m.vertices);
  add(m.triangles);
  add(m.material_ids);
  add(m.triangle_uvs);
  for (const Material& material : m.materials) {
    h = hash_bytes(h, material.name.data(), material.name.size());
    h = hash_bytes(h, &material.alpha_texture, sizeof material.alpha_texture);
  }
  return h;
}

}  // namespace rtsim::test
