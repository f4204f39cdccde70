// Bad input round two , the readers: bounded reads of regular files
// only, PLY bodies checked against their headers, assimp in a child process,
// strict numbers and duplicate keys.
#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/mesh_loader.h>

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

using namespace rtsim;
namespace fs = std::filesystem;

namespace {

fs::path scratch() {
  static const fs::path dir = [] {
    const fs::path d = fs::temp_directory_path() / ("rtsim_bounded_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

fs::path write(const std::string& name, const std::string& text) {
  const fs::path p = scratch() / name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const char* kQuadHeader =
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 2\nproperty list uchar int vertex_indices\nend_header\n";

}  // namespace

TEST(BoundedInput, FifoAndDeviceAreRefusedWithoutBlocking) {
  const fs::path fifo = scratch() / "fifo.toml";
  fs::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  const std::string why = error_of([&] { read_input_file(fifo, kMaxConfigFileBytes); });
  EXPECT_NE(why.find("FIFO"), std::string::npos) << why;
  const fs::path device = scratch() / "zero.toml";
  fs::remove(device);
  fs::create_symlink("/dev/zero", device);
  const std::string why_device = error_of([&] { parse_config_file(device); });
  EXPECT_NE(why_device.find("character device"), std::string::npos) << why_device;
  EXPECT_NE(why_device.find(device.string()), std::string::npos) << why_device;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(BoundedInput, FoldersAndFilesPastTheLimitAreRefused) {
  EXPECT_NE(error_of([&] { read_input_file(scratch(), kMaxConfigFileBytes); }).find("is a folder"),
            std::string::npos);
  const fs::path big = write("big.toml", std::string(4096, '#'));
  const std::string why = error_of([&] { read_input_file(big, 1024); });
  EXPECT_NE(why.find("past the limit of 1024 bytes"), std::string::npos) << why;
  EXPECT_EQ(read_input_file(big, 4096).size(), 4096u);
}

TEST(BoundedInput, NumbersAreStrict) {
  uint32_t w = 0, h = 0;
  EXPECT_TRUE(parse_resolution_text("64x48", w, h));
  EXPECT_EQ(w, 64u);
  EXPECT_EQ(h, 48u);
  // 4294967360 = 2^32 + 64: sscanf("%u") wrapped it to 64.
  for (const char* bad : {"4294967360x64", "64x4294967360", "+64x64", "64x64 ", " 64x64", "64x64x", "0x64",
                          "16385x1", "x64", "64x", "6 4x64", "-1x64", "99999999999999999999999x1"})
    EXPECT_FALSE(parse_resolution_text(bad, w, h)) << bad;
  uint64_t v = 0;
  EXPECT_FALSE(parse_unsigned("18446744073709551616", 0, UINT64_MAX, v));
  EXPECT_TRUE(parse_unsigned("18446744073709551615", 0, UINT64_MAX, v));
}

TEST(BoundedInput, JsonKeysDefinedTwiceAreRefusedWithTheirPath) {
  const std::string why = error_of([] {
    parse_config_text(R"({"camera": [{"name": "a", "fov": 40, "fov": 50}]})", "s.json", false);
  });
  EXPECT_NE(why.find("s.json: key 'camera.fov'"), std::string::npos) << why;
  EXPECT_NE(why.find("defined twice"), std::string::npos) << why;
  // The same key in two different objects is fine.
  EXPECT_NO_THROW(parse_config_text(R"({"a": {"x": 1}, "b": {"x": 2}})", "s.json", false));
}

TEST(PlyCheck, BodiesShorterThanTheirHeaderAreRefused) {
  const std::string body = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
  EXPECT_NO_THROW(check_ply_against_header(std::string(kQuadHeader) + body, "q.ply"));
  // Every cut of the body is refused, naming the element that is short.
  for (size_t cut = 0; cut + 1 < body.size(); ++cut) {
    const std::string text = std::string(kQuadHeader) + body.substr(0, cut);
    const std::string why = error_of([&] { check_ply_against_header(text, "q.ply"); });
    EXPECT_NE(why.find("body ends early"), std::string::npos) << "cut " << cut << ": " << why;
  }
  // 1000 faces announced, 1 present (assimp loaded this as 1000 triangles).
  std::string many = kQuadHeader;
  many.replace(many.find("face 2"), 6, "face 1000");
  const std::string why = error_of([&] { check_ply_against_header(many + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n", "q.ply"); });
  EXPECT_NE(why.find("announces 1000 'face' elements, the body holds 1"), std::string::npos) << why;
}

TEST(PlyCheck, BinaryBodiesAreWalkedWithTheirListLengths) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  std::string body(36, '\0');
  body += '\3';
  body += std::string(12, '\0');
  EXPECT_NO_THROW(check_ply_against_header(header + body, "b.ply"));
  for (size_t cut : {0, 10, 36, 37, 48}) {
    const std::string why = error_of([&] { check_ply_against_header(header + body.substr(0, cut), "b.ply"); });
    EXPECT_NE(why.find("body ends early"), std::string::npos) << cut << ": " << why;
  }
  // A list length that would run past the end.
  std::string long_list = body;
  long_list[36] = char(200);
  EXPECT_NE(error_of([&] { check_ply_against_header(header + long_list, "b.ply"); }).find("body ends early"),
            std::string::npos);
  // A count no file could hold is refused without walking it.
  std::string huge = header;
  huge.replace(huge.find("vertex 3"), 8, "vertex 9999999999999999");
  EXPECT_NE(error_of([&] { check_ply_against_header(huge + body, "b.ply"); }).find("body ends early"),
            std::string::npos);
}

// Faces of fewer than three corners abort assimp's triangulation (ai_assert in
// TriangulateProcess.cpp; found by fuzz_mesh); indices past the vertices make no
// triangle. Both are refused, ASCII and binary.
TEST(PlyCheck, FacesNeedThreeCornersAmongTheVertices) {
  const std::string vertices = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
  for (const char* faces : {"3 0 1 2\n2 0 1\n", "3 0 1 2\n0\n", "3 0 1 2\n3 0 1 4\n", "3 0 1 2\n3 0 -1 2\n"}) {
    const std::string why = error_of([&] { check_ply_against_header(std::string(kQuadHeader) + vertices + faces, "f.ply"); });
    EXPECT_NE(why.find("f.ply: PLY body: face 1 "), std::string::npos) << faces << ": " << why;
  }
  const std::string header =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  std::string two_corners = std::string(36, '\0') + '\2' + std::string(8, '\0');
  EXPECT_NE(error_of([&] { check_ply_against_header(header + two_corners, "b.ply"); }).find("has 2 corners"),
            std::string::npos);
  std::string past = std::string(36, '\0') + '\3' + std::string(11, '\0') + '\7';  // corner 7 of 3 vertices
  EXPECT_NE(error_of([&] { check_ply_against_header(header + past, "b.ply"); }).find("names vertex 7"),
            std::string::npos);
}

TEST(PlyCheck, MalformedHeadersAreRefused) {
  for (const char* bad : {"plx\n", "ply\nformat ascii 1.0\n", "ply\nend_header\n",
                          "ply\nformat ascii 1.0\nproperty float x\nend_header\n",
                          "ply\nformat ascii 1.0\nelement vertex -1\nend_header\n",
                          "ply\nformat ascii 1.0\nelement vertex 1\nproperty float3 x\nend_header\n",
                          "ply\nformat utf8 1.0\nend_header\n"}) {
    EXPECT_NE(error_of([&] { check_ply_against_header(bad, "h.ply"); }).find("h.ply: PLY"), std::string::npos)
        << bad;
  }
}

// What used to abort rtsim inside assimp (ai_assert in TriangulateProcess.cpp):
// now an InputError from the header check, and never a dead process.
TEST(PlyCheck, TruncatedPlyThroughTheLoaderIsAnInputError) {
  const fs::path cut = write("cut.ply", std::string(kQuadHeader) + "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0");
  const std::string why = error_of([&] { load_mesh(cut); });
  EXPECT_NE(why.find(cut.string()), std::string::npos) << why;
  EXPECT_NE(why.find("body ends early"), std::string::npos) << why;
}

// assimp runs in a child process: a good mesh comes back whole, materials included.
TEST(AssimpIsolation, MeshesComeBackFromTheChildIntact) {
  const fs::path obj = write("two.obj", "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl red\nf 1 2 3\n"
                                        "usemtl blue\nf 1 3 4\n");
  write("two.mtl", "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n");
  const Mesh isolated = load_mesh(obj);
  const Mesh direct = load_mesh_assimp_in_process(obj);
  ASSERT_EQ(isolated.triangles.size(), 2u);
  EXPECT_EQ(isolated.vertices, direct.vertices);
  EXPECT_EQ(isolated.triangles, direct.triangles);
  EXPECT_EQ(isolated.material_ids, direct.material_ids);
  ASSERT_EQ(isolated.materials.size(), direct.materials.size());
  for (size_t i = 0; i < direct.materials.size(); ++i) {
    EXPECT_EQ(isolated.materials[i].name, direct.materials[i].name);
    EXPECT_EQ(isolated.materials[i].albedo, direct.materials[i].albedo);
  }
  // assimp's own errors still arrive as InputErrors naming the file.
  const fs::path empty = write("empty.obj", "# nothing\n");
  EXPECT_NE(error_of([&] { load_mesh(empty); }).find(empty.string()), std::string::npos);
}

// What assimp does to a malformed file ends only its child process. A PLY body
// with faces of no corners makes assimp's triangulation abort (ai_assert in
// TriangulateProcess.cpp); under a name without .ply it skips rtsim's PLY check,
// and assimp still recognises it by content: rtsim died of SIGABRT here before.
TEST(AssimpIsolation, AnAbortInsideAssimpIsAnInputError) {
  const std::string header =
      "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string body = std::string(48, '\0') + '\0' + '\0' + std::string(4, '\1');
  const fs::path file = write("disguised.dat", header + body);
  const std::string why = error_of([&] { load_mesh(file); });
  EXPECT_NE(why.find(file.string() + ": assimp crashed reading it (signal 6"), std::string::npos) << why;
  // With its own name, the header check says what is wrong before assimp runs.
  const fs::path named = write("honest.ply", header + body);
  EXPECT_NE(error_of([&] { load_mesh(named); }).find("face 0 has 0 corners"), std::string::npos);
}
