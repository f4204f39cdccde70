// Ray file: round trip and refusal of bad files.
#include <rtsim/model/core/ray_file.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <unistd.h>

using namespace rtsim;
namespace fs = std::filesystem;

namespace {
fs::path temp_path(const std::string& name) {
  return fs::temp_directory_path() / ("rtsim_core_" + std::to_string(::getpid()) + "_" + name);
}
RaySet sample_set() {
  RaySet set;
  set.scene_hash = 0x1234'5678'9abc'def0ull;
  for (uint32_t i = 0; i < 10000; ++i) {
    Ray r;
    r.origin = vec3(float(i), -0.5f * float(i), 1e-7f * float(i));
    r.direction = vec3(0.0f, -0.0f, 1.0f + float(i));
    r.tmin = 1e-3f;
    r.tmax = i % 2 ? std::numeric_limits<float>::infinity() : 10.0f + float(i);
    r.type = kAllRayTypes[i % kRayTypeCount];
    r.bounce = uint8_t(i % 3);
    r.pixel = i * 3;
    r.sample = i % 4;
    r.parent = i == 0 ? kNoParent : i - 1;
    set.rays.push_back(r);
  }
  return set;
}
std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
void expect_refused(const fs::path& p, const std::string& needle) {
  try {
    read_ray_file(p);
    FAIL() << "accepted a bad file, expected " << needle;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(p.string()), std::string::npos) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}
}  // namespace

TEST(CoreRayFile, RoundTripIsExact) {
  const fs::path p = temp_path("round.rays");
  const RaySet set = sample_set();
  write_ray_file(p, set);
  EXPECT_EQ(fs::file_size(p), 32u + 48u * set.rays.size());
  const RaySet back = read_ray_file(p);
  EXPECT_EQ(back.scene_hash, set.scene_hash);
  ASSERT_EQ(back.rays.size(), set.rays.size());
  for (size_t i = 0; i < set.rays.size(); ++i) {
    const Ray &a = set.rays[i], &b = back.rays[i];
    EXPECT_EQ(a.origin, b.origin);
    EXPECT_EQ(std::signbit(a.direction.y), std::signbit(b.direction.y));
    EXPECT_EQ(a.direction, b.direction);
    EXPECT_EQ(a.tmin, b.tmin);
    EXPECT_EQ(a.tmax, b.tmax);
    EXPECT_EQ(a.type, b.type);
    EXPECT_EQ(a.bounce, b.bounce);
    EXPECT_EQ(a.pixel, b.pixel);
    EXPECT_EQ(a.sample, b.sample);
    EXPECT_EQ(a.parent, b.parent);
  }
  fs::remove(p);
}

TEST(CoreRayFile, CorruptOrTruncatedFilesAreRefusedNamingTheFieldAndOffset) {
  const fs::path good = temp_path("good.rays");
  write_ray_file(good, sample_set());
  const std::string bytes = bytes_of(good);
  const fs::path bad = temp_path("bad.rays");
  auto variant = [&](const std::string& contents, const std::string& needle) {
    write_file_atomic(bad, contents);
    expect_refused(bad, needle);
  };
  variant(bytes.substr(0, 20), "header: truncated");
  variant(bytes.substr(0, bytes.size() - 1), "ray count");
  variant(bytes + "x", "ray count");
  std::string b = bytes;
  b[0] = 'X';
  variant(b, "magic");
  b = bytes;
  b[8] = 7;
  variant(b, "version");
  b = bytes;
  b[12] = 40;
  variant(b, "record_bytes");
  b = bytes;
  b[32 + 48 * 5 + 32] = char(kRayTypeCount);  // ray 5's type: the first unknown one
  variant(b, "offset " + std::to_string(32 + 48 * 5 + 32) + ": ray 5 type");
  b = bytes;
  b[32 + 48 * 2 + 3] = char(0x7f), b[32 + 48 * 2 + 2] = char(0xc0);  // ray 2 origin.x = NaN
  variant(b, "ray 2 origin");
  b = bytes;
  for (int k = 0; k < 12; ++k) b[32 + 48 * 4 + 16 + k] = 0;  // ray 4 direction = 0
  variant(b, "ray 4 direction");
  expect_refused(temp_path("does_not_exist.rays"), "no such file");
  fs::remove(good);
  fs::remove(bad);
}
