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

#include <rtsim/workloads/files.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/fork.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

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

Mesh flatten(const Mesh& mesh) {
  if (mesh.instances.empty()) return mesh;
  // Through flatten(Scene): one definition of the flat form for meshes and scenes.
  Scene scene;
  scene.name = "mesh";
  scene.vertices = mesh.vertices;
  scene.triangles = mesh.triangles;
  scene.material_ids = mesh.material_ids;
  scene.triangle_uvs = mesh.triangle_uvs;
  scene.meshes = mesh.meshes;
  scene.instances = mesh.instances;
  Scene flat = flatten(scene);
  Mesh out;
  out.vertices = std::move(flat.vertices);
  out.triangles = std::move(flat.triangles);
  out.material_ids = std::move(flat.material_ids);
  out.triangle_uvs = std::move(flat.triangle_uvs);
  out.materials = mesh.materials;
  out.alpha_textures = mesh.alpha_textures;
  out.suggested_cameras = mesh.suggested_cameras;
  out.dropped_sky_faces = mesh.dropped_sky_faces;
  out.dropped_tool_faces = mesh.dropped_tool_faces;
  out.alpha_textures_missing = mesh.alpha_textures_missing;
  return out;
}

std::vector<uint8_t> read_file_bytes(const std::filesystem::path& path) {
  const std::string bytes = read_input_file(path, kMaxDataFileBytes);
  return std::vector<uint8_t>(bytes.begin(), bytes.end());
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
  // The member's header states its size, and a hostile one can say 3 GB in a 1 KB
  // archive: a size deflate cannot reach from the compressed bytes (at most about
  // 1032:1) is refused, so is one past the data limit or the memory limit, and the
  // bytes are read in chunks, so that what is allocated is what arrives.
  constexpr uint64_t kMaxDeflateRatio = 1032;
  const std::string name = archive.string() + ":" + member;
  if ((stat.valid & ZIP_STAT_COMP_SIZE) && stat.size > saturating_add(saturating_mul(stat.comp_size, kMaxDeflateRatio), 1024)) {
    zip_fclose(file);
    throw InputError(name, "declares " + std::to_string(stat.size) + " bytes from " + std::to_string(stat.comp_size) +
                               " compressed: more than deflate can expand (the archive is damaged or hostile)");
  }
  if (stat.size > kMaxDataFileBytes) {
    zip_fclose(file);
    throw InputError(name, "declares " + memory_text(stat.size) + ", over the " + memory_text(kMaxDataFileBytes) +
                               " limit of data files");
  }
  try {
    check_memory_budget(stat.size, name, "the member's declared size");
  } catch (...) {
    zip_fclose(file);
    throw;
  }
  std::vector<uint8_t> bytes;
  zip_uint64_t done = 0;
  while (done < stat.size) {
    const zip_uint64_t chunk = std::min<zip_uint64_t>(stat.size - done, zip_uint64_t(1) << 20);
    bytes.resize(size_t(done + chunk));
    const zip_int64_t n = zip_fread(file, bytes.data() + done, chunk);
    if (n <= 0) {
      const std::string reason = n == 0 ? std::string("the member ends early") : zip_file_strerror(file);
      zip_fclose(file);
      throw InputError(name, "read failed after " + std::to_string(done) + " of " + std::to_string(stat.size) +
                                 " bytes: " + reason);
    }
    done += zip_uint64_t(n);
  }
  bytes.resize(size_t(done));
  zip_fclose(file);
  return bytes;
}

Mesh load_mesh_assimp_in_process(const std::filesystem::path& path) {
  check_input_file(path, kMaxDataFileBytes);
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

// Sanitizer runtimes provide it; without one the weak reference stays null.
extern "C" void __sanitizer_set_death_callback(void (*callback)(void)) __attribute__((weak));

namespace {

// ---- assimp in a child process
// assimp stops the process on some malformed files (ai_assert aborts, and worse),
// so it reads in a forked child that sends the mesh back through a pipe; a child
// that dies takes only itself down, and its last words on stderr become the
// InputError. The mesh travels as plain arrays (MeshWire below).

void put_bytes(std::string& out, const void* p, size_t n) { out.append(static_cast<const char*>(p), n); }
template <class T>
void put_value(std::string& out, const T& v) { put_bytes(out, &v, sizeof v); }
void put_text(std::string& out, const std::string& s) {
  put_value(out, uint64_t(s.size()));
  out += s;
}

std::string encode_mesh(const Mesh& mesh) {
  std::string out;
  put_value(out, uint64_t(mesh.vertices.size()));
  put_bytes(out, mesh.vertices.data(), mesh.vertices.size() * sizeof(vec3));
  put_value(out, uint64_t(mesh.triangles.size()));
  put_bytes(out, mesh.triangles.data(), mesh.triangles.size() * sizeof(uvec3));
  put_bytes(out, mesh.material_ids.data(), mesh.material_ids.size() * sizeof(uint32_t));
  put_value(out, uint64_t(mesh.materials.size()));
  for (const Material& m : mesh.materials) {
    put_text(out, m.name);
    put_value(out, m.albedo);
    put_value(out, m.reflectance);
    put_value(out, m.transmittance);
    put_value(out, m.ior);
    put_value(out, m.emission);
  }
  return out;
}

// Reads what encode_mesh wrote; the bytes come from our own child, so a short
// message only means the child died while writing.
class MeshWire {
 public:
  MeshWire(const std::string& bytes, const std::string& file) : bytes_(bytes), file_(file) {}
  template <class T>
  T value() {
    T v;
    take(&v, sizeof v);
    return v;
  }
  void take(void* p, uint64_t n) {
    if (n > bytes_.size() - at_) throw InputError(file_, "the assimp reader stopped in the middle of its answer");
    std::memcpy(p, bytes_.data() + at_, n);
    at_ += n;
  }
  uint64_t count(uint64_t item_bytes) {
    const uint64_t n = value<uint64_t>();
    if (item_bytes && n > (bytes_.size() - at_) / item_bytes)
      throw InputError(file_, "the assimp reader stopped in the middle of its answer");
    return n;
  }
  std::string text() {
    std::string s(count(1), '\0');
    take(s.data(), s.size());
    return s;
  }

 private:
  const std::string& bytes_;
  std::string file_;
  uint64_t at_ = 0;
};

Mesh decode_mesh(const std::string& bytes, const std::string& file) {
  MeshWire in(bytes, file);
  Mesh mesh;
  mesh.vertices.resize(in.count(sizeof(vec3)));
  in.take(mesh.vertices.data(), mesh.vertices.size() * sizeof(vec3));
  mesh.triangles.resize(in.count(sizeof(uvec3) + sizeof(uint32_t)));
  in.take(mesh.triangles.data(), mesh.triangles.size() * sizeof(uvec3));
  mesh.material_ids.resize(mesh.triangles.size());
  in.take(mesh.material_ids.data(), mesh.material_ids.size() * sizeof(uint32_t));
  mesh.materials.resize(in.count(8));
  for (Material& m : mesh.materials) {
    m.name = in.text();
    m.albedo = in.value<vec3>();
    m.reflectance = in.value<float>();
    m.transmittance = in.value<float>();
    m.ior = in.value<float>();
    m.emission = in.value<vec3>();
  }
  return mesh;
}

void write_all(int fd, const std::string& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    done += size_t(n);
  }
}

// The last non-empty line of what the child printed (assimp's assert message).
std::string last_line(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  const size_t nl = text.rfind('\n');
  text = nl == std::string::npos ? text : text.substr(nl + 1);
  return text.size() > 300 ? text.substr(0, 300) + "..." : text;
}

}  // namespace

Mesh load_mesh_assimp(const std::filesystem::path& path) {
  check_input_file(path, kMaxDataFileBytes);
  // assimp trusts a PLY header's counts (see ply_check.cpp): check them first,
  // for a message that says what is wrong with the file.
  {
    std::string ext = lower(path.extension().string());
    if (ext == ".ply") check_ply_against_header(read_input_file(path, kMaxDataFileBytes), path.string());
  }
  int mesh_pipe[2], error_pipe[2];
  if (::pipe2(mesh_pipe, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  if (::pipe2(error_pipe, O_CLOEXEC) != 0) {
    ::close(mesh_pipe[0]), ::close(mesh_pipe[1]);
    throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  }
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t child = fork_without_workers();
  if (child < 0) {
    for (int fd : {mesh_pipe[0], mesh_pipe[1], error_pipe[0], error_pipe[1]}) ::close(fd);
    throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  }
  if (child == 0) {
    // The child: read, answer, _exit (no atexit handlers, no destructors of the
    // parent's objects). Status byte 0 = a mesh follows, 1 = an InputError text.
    ::close(mesh_pipe[0]);
    ::close(error_pipe[0]);
    ::dup2(error_pipe[1], 2);
    // A crash here is the answer, not an event for handlers the parent installed
    // (a sanitizer's or a fuzzer's would report the child's death as their own).
    for (int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGTRAP}) std::signal(sig, SIG_DFL);
    if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(nullptr);
    std::string answer;
    int code = 0;
    try {
      answer = std::string(1, '\0') + encode_mesh(load_mesh_assimp_in_process(path));
    } catch (const InputError& e) {
      answer = std::string(1, '\1') + e.what();
    } catch (const std::exception& e) {
      answer = std::string(1, '\1') + path.string() + ": assimp failed: " + e.what();
      code = 3;
    }
    write_all(mesh_pipe[1], answer);
    ::_exit(code);
  }
  ::close(mesh_pipe[1]);
  ::close(error_pipe[1]);
  // Read both pipes to the end (a full pipe would stall the child), then reap it.
  std::string answer, errors;
  pollfd fds[2] = {{mesh_pipe[0], POLLIN, 0}, {error_pipe[0], POLLIN, 0}};
  int open_pipes = 2;
  char buffer[65536];
  while (open_pipes > 0) {
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    for (int k = 0; k < 2; ++k) {
      if (fds[k].fd < 0 || !(fds[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t n = ::read(fds[k].fd, buffer, sizeof buffer);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        ::close(fds[k].fd);
        fds[k].fd = -1;
        --open_pipes;
        continue;
      }
      std::string& sink = k == 0 ? answer : errors;
      if (k == 1 && sink.size() > 65536) sink.erase(0, sink.size() - 32768);  // the tail is what counts
      sink.append(buffer, size_t(n));
    }
  }
  for (const pollfd& f : fds)
    if (f.fd >= 0) ::close(f.fd);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const std::string said = last_line(errors);
    throw InputError(path.string(), "assimp crashed reading it (signal " + std::to_string(sig) + ", " +
                                        strsignal(sig) + ")" + (said.empty() ? "" : ": " + said) +
                                        "; the file is malformed");
  }
  if (answer.empty()) throw InputError(path.string(), "assimp stopped without an answer" +
                                                          (errors.empty() ? "" : ": " + last_line(errors)));
  if (answer[0] == '\1') throw InputError(answer.substr(1));
  return decode_mesh(answer.substr(1), path.string());
}

namespace {
std::atomic<uint64_t> g_mesh_files_loaded{0};
}  // namespace

uint64_t mesh_files_loaded() { return g_mesh_files_loaded.load(); }

Mesh load_mesh(const std::filesystem::path& path, const MeshOptions& options) {
  if (!path_exists(path)) throw InputError(path.string(), "no such file or folder");
  ++g_mesh_files_loaded;
  const std::string ext = lower(path.extension().string());
  const std::string file_name = lower(path.filename().string());
  if (ext == ".bsp") return parse_q3bsp(read_file_bytes(path), path.string(), options);
  if (ext == ".pk3") {
    check_input_file(path, kMaxDataFileBytes);  // libzip opens it itself
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
  if (is_folder(path)) {
    if (path_exists(path / "scene.xml")) return load_stk_track(path);
    throw InputError(path.string(), "a folder, but not a SuperTuxKart track (no scene.xml)");
  }
  return load_mesh_assimp(path);
}

}  // namespace rtsim
