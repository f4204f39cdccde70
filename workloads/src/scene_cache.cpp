#include <rtsim/workloads/random.h>
#include <rtsim/workloads/scene_cache.h>
#include <rtsim/workloads/scene_registry.h>

#include <cstdlib>
#include <cstring>
#include <type_traits>

namespace rtsim {

namespace {

// "RTSIMSCN" and the format's version: a new Scene field is a new version.
constexpr char kMagic[8] = {'R', 'T', 'S', 'I', 'M', 'S', 'C', 'N'};
// 2: alpha textures and texture coordinates; 3: the scene as parsed (validated on
// every load), meshes and instances.
constexpr uint32_t kVersion = 3;

class Writer {
 public:
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void text(const std::string& s) {
    pod(uint64_t(s.size()));
    out_ += s;
  }
  template <class T>
  void array(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    pod(uint64_t(v.size()));
    if (!v.empty()) out_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string& bytes() { return out_; }

 private:
  std::string out_;
};

// Every read is bounded by what is left: a count past the end fails the whole read.
class Reader {
 public:
  Reader(const char* data, size_t size) : p_(data), end_(data + size) {}
  template <class T>
  bool pod(T* v) {
    if (size_t(end_ - p_) < sizeof(T)) return false;
    std::memcpy(v, p_, sizeof(T));
    p_ += sizeof(T);
    return true;
  }
  bool text(std::string* s) {
    uint64_t n = 0;
    if (!pod(&n) || n > uint64_t(end_ - p_)) return false;
    s->assign(p_, size_t(n));
    p_ += n;
    return true;
  }
  template <class T>
  bool array(std::vector<T>* v) {
    uint64_t n = 0;
    if (!pod(&n) || n > uint64_t(end_ - p_) / sizeof(T)) return false;
    v->resize(size_t(n));
    if (n > 0) std::memcpy(v->data(), p_, size_t(n) * sizeof(T));  // an empty vector's data() may be null
    p_ += n * sizeof(T);
    return true;
  }
  bool at_end() const { return p_ == end_; }

 private:
  const char* p_;
  const char* end_;
};

// Instances are written as they lie in memory: no padding, so no indeterminate bytes.
static_assert(sizeof(Instance) == sizeof(uint32_t) + sizeof(glm::mat4), "Instance has padding");

void write_body(Writer& w, const Scene& s) {
  w.text(s.name);
  w.text(s.source);
  w.text(s.licence);
  w.array(s.vertices);
  w.array(s.triangles);
  w.array(s.material_ids);
  w.pod(uint64_t(s.materials.size()));
  for (const Material& m : s.materials) {
    w.text(m.name);
    const float f[] = {m.albedo.x, m.albedo.y, m.albedo.z, m.reflectance, m.transmittance, m.ior,
                       m.emission.x, m.emission.y, m.emission.z};
    w.pod(f);
    w.pod(m.alpha_texture);
    w.pod(m.alpha_cutoff);
  }
  w.pod(uint64_t(s.alpha_textures.size()));
  for (const AlphaTexture& t : s.alpha_textures) {
    w.text(t.file);
    w.pod(t.width);
    w.pod(t.height);
    w.array(t.alpha);
  }
  w.array(s.triangle_uvs);
  w.pod(uint64_t(s.lights.size()));
  for (const Light& l : s.lights) {
    w.pod(uint32_t(l.kind));
    w.pod(l.position);
    w.pod(l.direction);
    w.pod(l.intensity);
  }
  w.pod(uint64_t(s.cameras.size()));
  for (const Camera& c : s.cameras) {
    w.text(c.name);
    w.pod(c.position);
    w.pod(c.target);
    w.pod(c.up);
    w.pod(c.vertical_fov_deg);
  }
  w.pod(uint8_t(s.ao.enabled));
  w.pod(s.ao.cutoff_relative);
  w.pod(s.ao.samples);
  w.pod(s.validation);
  w.pod(uint64_t(s.meshes.size()));
  for (const SceneMesh& m : s.meshes) {
    w.text(m.name);
    const uint32_t range[] = {m.first_vertex, m.vertex_count, m.first_triangle, m.triangle_count};
    w.pod(range);
  }
  w.array(s.instances);
}

bool read_body(Reader& r, Scene* s) {
  uint64_t n = 0;
  if (!r.text(&s->name) || !r.text(&s->source) || !r.text(&s->licence) || !r.array(&s->vertices) ||
      !r.array(&s->triangles) || !r.array(&s->material_ids) || !r.pod(&n))
    return false;
  for (uint64_t i = 0; i < n; ++i) {
    Material m;
    float f[9];
    if (!r.text(&m.name) || !r.pod(&f) || !r.pod(&m.alpha_texture) || !r.pod(&m.alpha_cutoff)) return false;
    m.albedo = vec3(f[0], f[1], f[2]);
    m.reflectance = f[3], m.transmittance = f[4], m.ior = f[5];
    m.emission = vec3(f[6], f[7], f[8]);
    s->materials.push_back(m);
  }
  if (!r.pod(&n)) return false;
  for (uint64_t i = 0; i < n; ++i) {
    AlphaTexture t;
    if (!r.text(&t.file) || !r.pod(&t.width) || !r.pod(&t.height) || !r.array(&t.alpha) ||
        t.alpha.size() != uint64_t(t.width) * t.height)
      return false;
    s->alpha_textures.push_back(std::move(t));
  }
  if (!r.array(&s->triangle_uvs)) return false;
  if (!s->triangle_uvs.empty() && s->triangle_uvs.size() != s->triangles.size()) return false;
  for (const Material& m : s->materials)
    if (m.alpha_texture < -1 || m.alpha_texture >= int64_t(s->alpha_textures.size())) return false;
  if (!r.pod(&n)) return false;
  for (uint64_t i = 0; i < n; ++i) {
    Light l;
    uint32_t kind = 0;
    if (!r.pod(&kind) || kind > uint32_t(Light::Kind::Directional) || !r.pod(&l.position) ||
        !r.pod(&l.direction) || !r.pod(&l.intensity))
      return false;
    l.kind = Light::Kind(kind);
    s->lights.push_back(l);
  }
  if (!r.pod(&n)) return false;
  for (uint64_t i = 0; i < n; ++i) {
    Camera c;
    if (!r.text(&c.name) || !r.pod(&c.position) || !r.pod(&c.target) || !r.pod(&c.up) ||
        !r.pod(&c.vertical_fov_deg))
      return false;
    s->cameras.push_back(c);
  }
  uint8_t enabled = 0;
  if (!r.pod(&enabled) || !r.pod(&s->ao.cutoff_relative) || !r.pod(&s->ao.samples) || !r.pod(&s->validation))
    return false;
  s->ao.enabled = enabled != 0;
  if (!r.pod(&n)) return false;
  for (uint64_t i = 0; i < n; ++i) {
    SceneMesh m;
    uint32_t range[4];
    if (!r.text(&m.name) || !r.pod(&range)) return false;
    m.first_vertex = range[0], m.vertex_count = range[1], m.first_triangle = range[2], m.triangle_count = range[3];
    s->meshes.push_back(std::move(m));
  }
  if (!r.array(&s->instances)) return false;
  // The image holds the scene before validation (which drops bad indices, so they
  // may be here). What a parsed scene always has: one material id per triangle
  // naming a material; meshes that cover the triangles in order within the
  // vertices, and instances that name one (validation would refuse the rest, an
  // image that could not have been written).
  if (s->material_ids.size() != s->triangles.size()) return false;
  for (uint32_t m : s->material_ids)
    if (m >= s->materials.size()) return false;
  if (s->meshes.empty() != s->instances.empty()) return false;
  uint64_t next = 0;
  for (const SceneMesh& m : s->meshes) {
    if (m.first_triangle != next || uint64_t(m.first_vertex) + m.vertex_count > s->vertices.size()) return false;
    next += m.triangle_count;
  }
  if (!s->meshes.empty() && next != s->triangles.size()) return false;
  for (const Instance& i : s->instances)
    if (i.mesh >= s->meshes.size()) return false;
  return r.at_end();
}

}  // namespace

std::string scene_image(const Scene& scene, const std::string& key) {
  Writer body;
  write_body(body, scene);
  Writer w;
  w.pod(kMagic);
  w.pod(kVersion);
  w.text(key);
  w.pod(uint64_t(body.bytes().size()));
  w.pod(hash_bytes(0x53434E45ull, body.bytes().data(), body.bytes().size()));
  return w.bytes() + body.bytes();
}

std::optional<Scene> scene_from_image(const std::string& bytes, const std::string& key) {
  Reader r(bytes.data(), bytes.size());
  char magic[8];
  uint32_t version = 0;
  std::string stored_key;
  uint64_t size = 0, checksum = 0;
  if (!r.pod(&magic) || std::memcmp(magic, kMagic, sizeof magic) != 0 || !r.pod(&version) ||
      version != kVersion || !r.text(&stored_key) || stored_key != key || !r.pod(&size) || !r.pod(&checksum))
    return std::nullopt;
  const size_t header = bytes.size() - size_t(std::min<uint64_t>(size, bytes.size()));
  if (size > bytes.size() || header != 8 + 4 + 8 + key.size() + 8 + 8) return std::nullopt;
  const char* body = bytes.data() + header;
  if (hash_bytes(0x53434E45ull, body, size_t(size)) != checksum) return std::nullopt;
  Reader b(body, size_t(size));
  Scene scene;
  if (!read_body(b, &scene)) return std::nullopt;
  return scene;
}

std::filesystem::path scene_image_path(const std::string& key) {
  // The format's version in the name: binaries of two versions sharing a cache keep
  // an image each instead of replacing each other's as damaged.
  return scene_cache_dir() / "scene-images" / (key + ".v" + std::to_string(kVersion) + ".scene");
}

bool scene_cache_enabled() {
  const char* env = std::getenv("RTSIM_SCENE_CACHE");
  return !(env && (std::strcmp(env, "off") == 0 || std::strcmp(env, "0") == 0));
}

}  // namespace rtsim
