// Malformed scene inputs, through the command line a user runs: each gives a clear
// message naming the file and exit code 2, never a crash.
#include "cli_runner.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

struct BadSceneCase {
  const char* name;
  const char* mesh_file;                // written beside the descriptor
  std::vector<uint8_t> bytes;
  const char* mesh_options;             // extra keys in [[mesh]]
  const char* expected_in_message;      // a word the message must contain
};

std::vector<uint8_t> text(const std::string& s) { return {s.begin(), s.end()}; }

std::vector<uint8_t> bsp_header_only() {
  // "IBSP", version 46, then a lump directory cut short.
  std::vector<uint8_t> b = text("IBSP");
  const uint32_t version = 46;
  b.insert(b.end(), reinterpret_cast<const uint8_t*>(&version), reinterpret_cast<const uint8_t*>(&version) + 4);
  b.resize(40, 0);
  return b;
}

std::vector<uint8_t> bsp_wrong_magic() {
  std::vector<uint8_t> b = bsp_header_only();
  b[0] = 'X';
  b.resize(8 + 17 * 8, 0);
  return b;
}

class BadSceneFile : public ::testing::TestWithParam<BadSceneCase> {};

TEST_P(BadSceneFile, ExitsTwoNamingTheFile) {
  const BadSceneCase& c = GetParam();
  const fs::path dir = fs::temp_directory_path() / ("rtsim_bad_scene_" + std::string(c.name));
  fs::remove_all(dir);
  fs::create_directories(dir);
  {
    std::ofstream mesh(dir / c.mesh_file, std::ios::binary);
    mesh.write(reinterpret_cast<const char*>(c.bytes.data()), std::streamsize(c.bytes.size()));
    std::ofstream toml(dir / "scene.toml");
    toml << "name = \"bad\"\n[[mesh]]\nfile = \"" << c.mesh_file << "\"\n" << c.mesh_options
         << "\n[[camera]]\nname = \"view1\"\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\n";
  }
  const CliResult r = run_rtsim("scenes info " + (dir / "scene.toml").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("rtsim: error:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(c.expected_in_message), std::string::npos) << r.output;
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(
    Cli, BadSceneFile,
    ::testing::Values(
        BadSceneCase{"truncated_bsp", "map.bsp", bsp_header_only(), "", "map.bsp"},
        BadSceneCase{"wrong_magic_bsp", "map.bsp", bsp_wrong_magic(), "", "map.bsp"},
        BadSceneCase{"truncated_spm", "mesh.spm", text("SP"), "", "mesh.spm"},
        // Every face points past the vertex list: nothing survives validation.
        BadSceneCase{"bad_indices_ply", "mesh.ply",
                     text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                          "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                          "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
                     "", "bad"},
        // Every vertex is NaN: all triangles dropped by the load policy, then refused.
        BadSceneCase{"nan_obj", "mesh.obj", text("v nan 0 0\nv 1 nan 0\nv 0 1 nan\nf 1 2 3\n"), "",
                     "no valid triangle"},
        BadSceneCase{"not_a_zip_pk3", "maps.pk3", text("this is not a zip archive"),
                     "map = \"oacmpdm1\"", "maps.pk3"},
        BadSceneCase{"garbage_obj", "mesh.obj", text("\x01\x02\x03 not a mesh"), "", "mesh.obj"}),
    [](const ::testing::TestParamInfo<BadSceneCase>& info) { return std::string(info.param.name); });

TEST(Cli, ZipWithoutTheMapNamesTheMap) {
  const fs::path dir = fs::temp_directory_path() / "rtsim_bad_scene_zip_without_map";
  fs::remove_all(dir);
  fs::create_directories(dir);
  // A valid zip holding something else; Debian's python3 writes it (no zip tool needed).
  const std::string make_zip = "/usr/bin/python3 -c \"import zipfile; z = zipfile.ZipFile('" +
                               (dir / "maps.pk3").string() +
                               "', 'w'); z.writestr('readme.txt', 'no maps here'); z.close()\"";
  ASSERT_EQ(std::system(make_zip.c_str()), 0);
  {
    std::ofstream toml(dir / "scene.toml");
    toml << "name = \"bad\"\n[[mesh]]\nfile = \"maps.pk3\"\nmap = \"oacmpdm1\"\n"
         << "[[camera]]\nname = \"view1\"\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\n";
  }
  const CliResult r = run_rtsim("scenes info " + (dir / "scene.toml").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("oacmpdm1"), std::string::npos) << r.output;
  fs::remove_all(dir);
}

}  // namespace
