// Mesh loading: file-name dispatch, the assimp path for every format assimp
// reads, and the file/zip helpers shared by our own loaders (q3bsp.cpp,
// stk_track.cpp).
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/mesh_loader.h>

#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <zip.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <memory>

namespace rtsim {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

// Owns a libzip archive handle; InputError names the archive when it cannot be opened.
struct ZipArchive {
  zip_t* handle = nullptr;
  explicit ZipArchive(const std::filesystem::path& archive) {
    int code = 0;
    handle = zip_open(archive.string().c_str(), ZIP_RDONLY, &code);
    if (!handle) {
      zip_error_t error;
      zip_error_init_with_code(&error, code);
      const std::string reason = zip_error_strerror(&error);
      zip_error_fini(&error);
      throw InputError(archive.string(), "cannot open as a zip archive: " + reason);
    }
  }
  ~ZipArchive() {
    if (handle) zip_discard(handle);
  }
  ZipArchive(const ZipArchive&) = delete;
  ZipArchive& operator=(const ZipArchive&) = delete;
};

}  // namespace

std::vector<uint8_t> read_file_bytes(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path.string(), "no such file");
  if (std::filesystem::is_directory(path, ec)) throw InputError(path.string(), "is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "cannot open for reading");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(path.string(), "cannot determine the file size");
  in.seekg(0, std::ios::beg);
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), size))
    throw InputError(path.string(), "read failed");
  return bytes;
}

std::vector<std::string> list_zip_members(const std::filesystem::path& archive) {
  ZipArchive zip(archive);
  const zip_int64_t count = zip_get_num_entries(zip.handle, 0);
  std::vector<std::string> names;
  for (zip_int64_t i = 0; i < count; ++i)
    if (const char* name = zip_get_name(zip.handle, zip_uint64_t(i), 0)) names.emplace_back(name);
  return names;
}

std::vector<uint8_t> read_zip_member(const std::filesystem::path& archive, const std::string& member) {
  ZipArchive zip(archive);
  zip_stat_t stat;
  zip_stat_init(&stat);
  if (zip_stat(zip.handle, member.c_str(), 0, &stat) != 0 || !(stat.valid & ZIP_STAT_SIZE))
    throw InputError(archive.string(), "the archive has no member '" + member + "'");
  zip_file_t* file = zip_fopen(zip.handle, member.c_str(), 0);
  if (!file)
    throw InputError(archive.string() + ":" + member,
                     std::string("cannot open member: ") + zip_strerror(zip.handle));
  std::vector<uint8_t> bytes(static_cast<size_t>(stat.size));
  zip_uint64_t done = 0;
  while (done < stat.size) {
    const zip_int64_t n = zip_fread(file, bytes.data() + done, stat.size - done);
    if (n <= 0) {
      const std::string reason = zip_file_strerror(file);
      zip_fclose(file);
      throw InputError(archive.string() + ":" + member,
                       "read failed after " + std::to_string(done) + " of " +
                           std::to_string(stat.size) + " bytes: " + reason);
    }
    done += zip_uint64_t(n);
  }
  zip_fclose(file);
  return bytes;
}

Mesh load_mesh_assimp(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path.string(), "no such file");
  Assimp::Importer importer;
  // Points and lines carry no surface: SortByPType splits them out and this drops them.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const unsigned flags = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                         aiProcess_PreTransformVertices | aiProcess_SortByPType |
                         aiProcess_ValidateDataStructure;
  const aiScene* scene = importer.ReadFile(path.string(), flags);
  if (!scene || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) || !scene->mRootNode)
    throw InputError(path.string(), std::string("assimp cannot read it: ") + importer.GetErrorString());

  Mesh mesh;
  for (unsigned m = 0; m < scene->mNumMaterials; ++m) {
    const aiMaterial* source = scene->mMaterials[m];
    Material material;
    aiString name;
    material.name = source->Get(AI_MATKEY_NAME, name) == AI_SUCCESS && name.length > 0
                        ? std::string(name.C_Str())
                        : "material" + std::to_string(m);
    aiColor3D diffuse(0.7f, 0.7f, 0.7f);
    if (source->Get(AI_MATKEY_COLOR_DIFFUSE, diffuse) == AI_SUCCESS) {
      const vec3 albedo(diffuse.r, diffuse.g, diffuse.b);
      // Albedo above 1 would create energy; non-finite would poison shading.
      if (is_finite(albedo)) material.albedo = glm::clamp(albedo, vec3(0.0f), vec3(1.0f));
    }
    mesh.materials.push_back(material);
  }
  if (mesh.materials.empty()) mesh.materials.push_back(Material{});

  for (unsigned mi = 0; mi < scene->mNumMeshes; ++mi) {
    const aiMesh* source = scene->mMeshes[mi];
    if (!(source->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;
    const uint32_t base = uint32_t(mesh.vertices.size());
    for (unsigned v = 0; v < source->mNumVertices; ++v) {
      const aiVector3D& p = source->mVertices[v];
      mesh.vertices.emplace_back(p.x, p.y, p.z);
    }
    const uint32_t material =
        source->mMaterialIndex < mesh.materials.size() ? source->mMaterialIndex : 0;
    for (unsigned f = 0; f < source->mNumFaces; ++f) {
      const aiFace& face = source->mFaces[f];
      if (face.mNumIndices != 3) continue;  // stray point/line after triangulation
      mesh.triangles.emplace_back(base + face.mIndices[0], base + face.mIndices[1],
                                  base + face.mIndices[2]);
      mesh.material_ids.push_back(material);
    }
  }
  if (mesh.triangles.empty()) throw InputError(path.string(), "contains no triangles");
  return mesh;
}

Mesh load_mesh(const std::filesystem::path& path, const MeshOptions& options) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw InputError(path.string(), "no such file or folder");
  const std::string ext = lower(path.extension().string());
  const std::string file_name = lower(path.filename().string());
  if (ext == ".bsp") return parse_q3bsp(read_file_bytes(path), path.string(), options);
  if (ext == ".pk3") {
    std::string map = options.pk3_map;
    if (map.empty()) {
      // One map in the archive needs no name; several do.
      std::vector<std::string> maps;
      for (const std::string& member : list_zip_members(path))
        if (member.rfind("maps/", 0) == 0 && lower(member).size() > 9 &&
            lower(member).compare(member.size() - 4, 4, ".bsp") == 0)
          maps.push_back(member.substr(5, member.size() - 9));
      if (maps.size() != 1) {
        std::string names;
        for (const std::string& m : maps) names += (names.empty() ? "" : ", ") + m;
        throw InputError(path.string(), "name the map to load (the archive holds " +
                                            std::to_string(maps.size()) + " maps: " + names + ")");
      }
      map = maps.front();
    }
    const std::string member = "maps/" + map + ".bsp";
    return parse_q3bsp(read_zip_member(path, member), path.string() + ":" + member, options);
  }
  if (ext == ".spm") return parse_spm(read_file_bytes(path), path.string());
  if (file_name == "scene.xml") return load_stk_track(path.parent_path());
  if (std::filesystem::is_directory(path, ec)) {
    if (std::filesystem::exists(path / "scene.xml", ec)) return load_stk_track(path);
    throw InputError(path.string(), "a folder, but not a SuperTuxKart track (no scene.xml)");
  }
  return load_mesh_assimp(path);
}

}  // namespace rtsim
