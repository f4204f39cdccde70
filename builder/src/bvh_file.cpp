#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/random.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <sstream>

namespace rtsim {

namespace {
constexpr char kMagic[8] = {'R', 'T', 'S', 'I', 'M', 'B', 'V', 'H'};
constexpr size_t kNodeBytes = 36;     // version 2
constexpr size_t kNodeBytesV1 = 32;   // version 1: binary trees, no child count
constexpr uint32_t kMaxTextBytes = 1u << 20;

// The file's checksum: the shared content hash over every byte before it.
uint64_t checksum(const char* data, size_t size) { return hash_bytes(0x4256'4846'494C'4531ull, data, size); }

template <class T>
void put(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}
void put_text(std::string& out, const std::string& text) {
  put(out, uint32_t(text.size()));
  out += text;
}

// Reads fields from a byte buffer, naming the field in every error.
class Reader {
 public:
  Reader(const std::string& file, const std::string& data) : file_(file), data_(data) {}
  template <class T>
  T get(const std::string& field) {
    need(sizeof(T), field);
    T value;
    std::memcpy(&value, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  std::string text(const std::string& field) {
    const uint32_t size = get<uint32_t>(field + ".length");
    if (size > kMaxTextBytes) fail(field + ".length", "implausible length " + std::to_string(size));
    need(size, field);
    std::string s = data_.substr(pos_, size);
    pos_ += size;
    return s;
  }
  void need(uint64_t bytes, const std::string& field) const {
    if (bytes > data_.size() - pos_)
      fail(field, "file truncated (needs " + std::to_string(bytes) + " more bytes, " +
                      std::to_string(data_.size() - pos_) + " left)");
  }
  [[noreturn]] void fail(const std::string& field, const std::string& reason) const {
    throw InputError(file_ + ": " + field, reason);
  }
  size_t pos() const { return pos_; }
  size_t left() const { return data_.size() - pos_; }
  const char* here() const { return data_.data() + pos_; }
  void skip(size_t bytes) { pos_ += bytes; }

 private:
  std::string file_;
  const std::string& data_;
  size_t pos_ = 0;
};
}  // namespace

std::string build_params_json(const BuildParams& p) {
  // Every parameter the builder reads (registry), typed. Binary trees leave the width
  // out so that they keep their old hashes and job keys.
  nlohmann::json j;
  j["builder"] = p.builder;
  for (const BuilderParameter& parameter : builder_parameters()) {
    if (!parameter.in_tree_identity || !parameter_used_by(parameter, p.builder)) continue;
    if (parameter.key == "width" && p.width == 2) continue;
    std::visit([&](auto member) { j[parameter.key] = p.*member; }, parameter.field);
  }
  // Whether the AO pass ran or the caller supplied its values (tests, caches).
  if (parameter_used_by(*find_builder_parameter("ao_rays"), p.builder))
    j["occlusion_values_supplied"] = !p.occlusion_values.empty();
  return j.dump();
}

void save_bvh(const std::filesystem::path& path, const Bvh& bvh, const Scene& scene,
              const BuildParams& params) {
  BvhFileHeader header;
  header.scene_hash = scene.content_hash();
  header.triangle_count = scene.triangle_count();
  header.instance_count = bvh.two_level() ? scene.instances.size() : 0;
  header.builder = params.builder;
  header.params_json = build_params_json(params);
  save_bvh(path, bvh, header);
}

void save_bvh(const std::filesystem::path& path, const Bvh& bvh, const BvhFileHeader& header) {
  std::string out;
  out.reserve(128 + header.params_json.size() + bvh.nodes.size() * kNodeBytes +
              bvh.prim_refs.size() * 4);
  out.append(kMagic, sizeof kMagic);
  put(out, kBvhFileVersion);
  put(out, header.scene_hash);
  put(out, header.triangle_count);
  put_text(out, header.builder);
  put_text(out, header.params_json);
  put(out, uint64_t(bvh.nodes.size()));
  put(out, uint64_t(bvh.prim_refs.size()));
  put(out, bvh.tlas_nodes);
  put(out, header.instance_count);
  put(out, uint64_t(bvh.blas_roots.size()));
  for (uint32_t root : bvh.blas_roots) put(out, root);
  for (const BvhNode& n : bvh.nodes) {
    const float box[6] = {n.bounds.lo.x, n.bounds.lo.y, n.bounds.lo.z,
                          n.bounds.hi.x, n.bounds.hi.y, n.bounds.hi.z};
    out.append(reinterpret_cast<const char*>(box), sizeof box);
    put(out, n.index);
    put(out, n.count);
    put(out, n.children);
  }
  out.append(reinterpret_cast<const char*>(bvh.prim_refs.data()), bvh.prim_refs.size() * 4);
  put(out, checksum(out.data(), out.size()));
  write_file_atomic(path, out);
}

Bvh load_bvh(const std::filesystem::path& path, const Scene* scene, BvhFileHeader* header_out) {
  const std::string file = path.string();
  // The magic first, from the first bytes alone: a 2 GB file that is no BVH file
  // must not be read whole (it was: 4.2 GB peak and 48 s) to be refused.
  const uint64_t size = check_input_file(path, kMaxDataFileBytes);
  {
    char magic[sizeof kMagic] = {};
    std::ifstream in(path, std::ios::binary);
    in.read(magic, sizeof magic);
    if (size < sizeof kMagic || !in || std::memcmp(magic, kMagic, sizeof kMagic) != 0)
      throw InputError(file + ": header.magic", "not an rtsim BVH file (it does not start with RTSIMBVH)");
  }
  check_memory_budget(saturating_mul(size, 2), file, "the file's " + memory_text(size) + ", read whole, then its tree");
  const std::string data = read_input_file(path, kMaxDataFileBytes);
  Reader r(file, data);

  r.need(sizeof kMagic, "header.magic");
  if (std::memcmp(data.data(), kMagic, sizeof kMagic) != 0)
    r.fail("header.magic", "not an rtsim BVH file");
  r.skip(sizeof kMagic);
  BvhFileHeader h;
  h.version = r.get<uint32_t>("header.version");
  if (h.version < 1 || h.version > kBvhFileVersion)
    r.fail("header.version", "version " + std::to_string(h.version) + " is not supported (this rtsim reads 1 to " +
                                 std::to_string(kBvhFileVersion) + ")");
  const size_t node_bytes = h.version == 1 ? kNodeBytesV1 : kNodeBytes;
  h.scene_hash = r.get<uint64_t>("header.scene_hash");
  h.triangle_count = r.get<uint64_t>("header.triangle_count");
  h.builder = r.text("header.builder");
  h.params_json = r.text("header.parameters");
  // The builder must be one this rtsim knows (a tree is labelled with it in every
  // result, and a name that is not UTF-8 cannot even be written to JSON), and the
  // parameters a JSON object.
  const std::vector<std::string> known = builder_names();
  if (std::find(known.begin(), known.end(), h.builder) == known.end()) {
    std::string list;
    for (const std::string& b : known) list += (list.empty() ? "" : ", ") + b;
    std::string shown;
    for (unsigned char c : h.builder.substr(0, 64)) shown += c >= 0x20 && c < 0x7f ? char(c) : '?';
    r.fail("header.builder", "'" + shown + "' is not a builder this rtsim knows (" + list + ")");
  }
  {
    const nlohmann::json parameters = nlohmann::json::parse(h.params_json, nullptr, /*allow_exceptions=*/false);
    if (!parameters.is_object()) r.fail("header.parameters", "is not a JSON object");
  }
  const uint64_t node_count = r.get<uint64_t>("header.node_count");
  const uint64_t ref_count = r.get<uint64_t>("header.reference_count");
  Bvh bvh;
  if (h.version >= 3) {
    bvh.tlas_nodes = r.get<uint32_t>("header.tlas_nodes");
    h.instance_count = r.get<uint64_t>("header.instance_count");
    const uint64_t meshes = r.get<uint64_t>("header.mesh_count");
    if (meshes > r.left() / 4) r.fail("header.mesh_count", "implausible mesh count " + std::to_string(meshes));
    if ((meshes == 0) != (bvh.tlas_nodes == 0) || (meshes == 0) != (h.instance_count == 0))
      r.fail("header.tlas_nodes", "a two-level tree needs TLAS nodes, instances and meshes (the file has " +
                                      std::to_string(bvh.tlas_nodes) + ", " + std::to_string(h.instance_count) +
                                      " and " + std::to_string(meshes) + ")");
    bvh.blas_roots.resize(meshes);
    for (uint64_t m = 0; m < meshes; ++m) bvh.blas_roots[m] = r.get<uint32_t>("blas_roots[" + std::to_string(m) + "]");
  }
  // Sizes must match exactly: nodes, refs and the 8-byte checksum.
  if (node_count == 0 || node_count > r.left() / node_bytes)
    r.fail("header.node_count", "implausible node count " + std::to_string(node_count));
  if (ref_count > r.left() / 4)
    r.fail("header.reference_count", "implausible reference count " + std::to_string(ref_count));
  const uint64_t body = node_count * node_bytes + ref_count * 4 + 8;
  if (r.left() != body)
    r.fail(r.left() < body ? "nodes" : "trailer",
           r.left() < body ? "file truncated" : "unexpected bytes after the checksum");
  const size_t checked = data.size() - 8;
  uint64_t stored;
  std::memcpy(&stored, data.data() + checked, 8);
  if (stored != checksum(data.data(), checked))
    r.fail("checksum", "file is corrupt (checksum mismatch)");
  if (scene) {
    if (h.scene_hash != scene->content_hash())
      r.fail("header.scene_hash",
             "the file was built for another scene than '" + scene->name + "'" +
                 (bvh.two_level() && !scene->instanced()
                      ? " (it holds a two-level tree, of an instanced form: add --instanced)"
                  : !bvh.two_level() && scene->instanced()
                      ? " (it holds a one-level tree, of a flat form: leave out --instanced)"
                  : scene->alpha_made_opaque ? " (this run makes it opaque: was the tree built without --opaque?)"
                  : scene->alpha_tested_triangles() ? " (it has alpha-tested materials: was the tree built with --opaque?)"
                                                    : ""));
    if (h.triangle_count != scene->triangle_count())
      r.fail("header.triangle_count", "file has " + std::to_string(h.triangle_count) +
                                          " triangles, scene has " +
                                          std::to_string(scene->triangle_count()));
    if (h.instance_count != (bvh.two_level() ? scene->instances.size() : 0))
      r.fail("header.instance_count", "file has " + std::to_string(h.instance_count) + " instances, scene has " +
                                          std::to_string(scene->instances.size()));
  }
  if (bvh.tlas_nodes > node_count)
    r.fail("header.tlas_nodes", std::to_string(bvh.tlas_nodes) + " TLAS nodes in a tree of " +
                                    std::to_string(node_count));
  for (size_t m = 0; m < bvh.blas_roots.size(); ++m)
    if (bvh.blas_roots[m] != Bvh::kNoBlas && (bvh.blas_roots[m] < bvh.tlas_nodes || bvh.blas_roots[m] >= node_count))
      r.fail("blas_roots[" + std::to_string(m) + "]", "node " + std::to_string(bvh.blas_roots[m]) +
                                                          " is not a node after the TLAS's");
  bvh.nodes.resize(node_count);
  for (uint64_t i = 0; i < node_count; ++i) {
    float box[6];
    std::memcpy(box, r.here(), sizeof box);
    r.skip(sizeof box);
    BvhNode& n = bvh.nodes[i];
    n.bounds = Aabb{vec3(box[0], box[1], box[2]), vec3(box[3], box[4], box[5])};
    n.index = r.get<uint32_t>("nodes[" + std::to_string(i) + "].index");
    n.count = r.get<uint32_t>("nodes[" + std::to_string(i) + "].count");
    const std::string where = "nodes[" + std::to_string(i) + "]";
    if (h.version == 1)
      n.children = n.is_leaf() ? 0 : 2;
    else
      n.children = r.get<uint32_t>(where + ".children");
    if (!n.is_leaf() && (n.children < 2 || n.children > kMaxBvhWidth))
      r.fail(where + ".children", std::to_string(n.children) + " children (allowed 2.." +
                                      std::to_string(kMaxBvhWidth) + ")");
    if (n.is_leaf() && n.children != 0) r.fail(where + ".children", "a leaf has no children");
    if (n.is_leaf() ? uint64_t(n.index) + n.count > ref_count
                    : (uint64_t(n.index) + n.children > node_count || n.index <= i))
      r.fail(where, "index " + std::to_string(n.index) + " out of range");
  }
  bvh.prim_refs.resize(ref_count);
  std::memcpy(bvh.prim_refs.data(), r.here(), ref_count * 4);
  // A TLAS leaf's references name instances; every other one a triangle.
  std::vector<uint8_t> names_instance(ref_count, 0);
  for (uint32_t i = 0; i < bvh.tlas_nodes; ++i)
    if (bvh.nodes[i].is_leaf())
      std::fill_n(names_instance.begin() + bvh.nodes[i].index, bvh.nodes[i].count, uint8_t(1));
  for (uint64_t k = 0; k < ref_count; ++k)
    if (bvh.prim_refs[k] >= (names_instance[k] ? h.instance_count : h.triangle_count))
      r.fail("references[" + std::to_string(k) + "]",
             (names_instance[k] ? "instance " : "triangle ") + std::to_string(bvh.prim_refs[k]) + " does not exist");
  if (scene) {
    BvhLimits loose;
    loose.max_leaf_size = ~0u;
    loose.max_depth = ~0u;
    loose.max_width = kMaxBvhWidth;
    loose.split_references = true;
    loose.reference_budget = double(ref_count) / double(std::max<uint64_t>(1, h.triangle_count)) + 1;
    const BvhValidation v = validate_bvh(bvh, *scene, loose);
    if (!v.ok()) r.fail("nodes", "the tree is not valid for the scene: " + v.problems.front());
  }
  if (header_out) *header_out = h;
  return bvh;
}

}  // namespace rtsim
