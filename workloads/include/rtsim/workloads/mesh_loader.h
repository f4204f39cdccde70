#pragma once
// Mesh loaders: assimp for the formats it reads, our own for Quake 3 IBSP v46
// (.bsp, or a map inside a .pk3) and SuperTuxKart (.spm meshes, scene.xml tracks).
// Each is a pure function from bytes (or a folder) to a Mesh or an InputError
// naming the file, offset or field.
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace rtsim {

struct Mesh {
  std::vector<vec3> vertices;
  std::vector<uvec3> triangles;  // counter-clockwise seen from the front
  std::vector<uint32_t> material_ids;  // per triangle, into materials
  std::vector<Material> materials;
  // Alpha testing (Scene's fields of the same names): textures the materials'
  // alpha_texture index, and one TriangleUv per triangle or none.
  std::vector<AlphaTexture> alpha_textures;
  std::vector<TriangleUv> triangle_uvs;
  // Instancing (Scene's fields of the same names): both empty for a flat mesh.
  // SuperTuxKart tracks keep their model files as meshes and their objects as
  // instances; flatten() gives the flat mesh.
  std::vector<SceneMesh> meshes;
  std::vector<Instance> instances;
  std::vector<Camera> suggested_cameras;  // spawn points, track quads
  // Quake 3 faces left out on purpose (counted so that `scenes info` can say so):
  // sky faces (when MeshOptions::bsp_drop_sky) and tool faces (textures/common/:
  // clip, caulk, triggers, which no renderer draws).
  uint64_t dropped_sky_faces = 0;
  uint64_t dropped_tool_faces = 0;
  // SuperTuxKart tracks: alpha-tested textures (by file, or by name where no folder
  // has one) that could not be found or decoded; their materials stay opaque.
  uint64_t alpha_textures_missing = 0;
};

struct MeshOptions {
  int bsp_patch_level = 5;      // Bezier patch tessellation level
  bool bsp_drop_sky = true;     // drop faces whose texture has the sky flag (0x4)
  std::string pk3_map;          // map name inside a .pk3, e.g. "oacmpdm1"
};

// Dispatches on the file name: .bsp/.pk3, .spm, scene.xml (a STK track), else assimp.
// A track keeps its instances (flatten() for its flat triangles).
Mesh load_mesh(const std::filesystem::path& path, const MeshOptions& options = {});
// The flat mesh (every instance's triangles in world space, as flatten(Scene)); a
// flat mesh is returned unchanged.
Mesh flatten(const Mesh& mesh);
// load_mesh calls so far in this process, each of which reads and parses its file
// (a scene descriptor loads a file named by many [[mesh]] tables once).
uint64_t mesh_files_loaded();

// assimp, run in a forked child so that a file on which assimp aborts or crashes
// is an InputError, not the end of rtsim; a PLY is first checked against its
// own header (check_ply_against_header). The file must be a regular file within
// kMaxDataFileBytes (files.h).
Mesh load_mesh_assimp(const std::filesystem::path& path);
// The same in this process (what the child runs): only for tests and tools that
// want assimp's own behaviour.
Mesh load_mesh_assimp_in_process(const std::filesystem::path& path);
// InputError unless the PLY file's body holds every element its header announces
// (ASCII: enough numbers; binary: enough bytes) and the header is well formed.
void check_ply_against_header(std::string_view bytes, const std::string& file);
Mesh parse_q3bsp(const std::vector<uint8_t>& bytes, const std::string& file_name,
                 const MeshOptions& options = {});
// An SPM's triangle_uvs are its texture 1 coordinates (0, 0 for untextured
// materials); its materials are opaque (materials.xml lies beside it, see below).
Mesh parse_spm(const std::vector<uint8_t>& bytes, const std::string& file_name);
// A track folder's scene.xml: each model file once (a mesh, untransformed, in the
// track's materials) and each placement of one an instance (transform
// mirror * Irrlicht transform * mirror), the track's own model first; a placement
// whose transform is singular (STK's zero scales) is baked into a mesh of its own,
// placed by the identity. flatten() gives the flat track, exactly what this loader
// returned before it kept instances. Materials whose SuperTuxKart shader is
// "alphatest" (materials.xml of the object's folder, the track's, data/textures')
// get their texture's alpha channel from the first of those folders holding it.
Mesh load_stk_track(const std::filesystem::path& track_dir);
// The texture files load_stk_track would read for the track's alpha-tested
// materials (found, not decoded): what `scenes fetch` copies besides the meshes.
std::vector<std::filesystem::path> stk_track_alpha_texture_files(const std::filesystem::path& track_dir);

std::vector<uint8_t> read_file_bytes(const std::filesystem::path& path);  // InputError if unreadable
// Reads one member of a zip archive (libzip). InputError names archive and member.
std::vector<uint8_t> read_zip_member(const std::filesystem::path& archive, const std::string& member);
// Names of every member of a zip archive (libzip). InputError if it is not a zip.
std::vector<std::string> list_zip_members(const std::filesystem::path& archive);

}  // namespace rtsim
