#include <rtsim/workloads/error.h>
#include <rtsim/workloads/validate.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace rtsim {

namespace {
bool zero_area(const vec3& a, const vec3& b, const vec3& c) {
  // Double precision so that tiny but valid triangles are not called degenerate.
  const dvec3 n = glm::cross(dvec3(b) - dvec3(a), dvec3(c) - dvec3(a));
  return glm::dot(n, n) == 0.0;
}

// An instanced scene's structure: InputError for what no dropping can repair.
void check_instancing(const Scene& scene, const std::string& where) {
  if (scene.instances.empty())
    throw InputError(where, "has " + std::to_string(scene.meshes.size()) + " meshes but no instance places them");
  uint64_t next = 0;  // meshes cover the triangles in order
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const SceneMesh& mesh = scene.meshes[m];
    const std::string what = where + " mesh " + std::to_string(m) + " ('" + mesh.name + "')";
    if (mesh.first_triangle != next)
      throw InputError(what, "starts at triangle " + std::to_string(mesh.first_triangle) + ", not at " +
                                 std::to_string(next) + " where the mesh before it ends (meshes cover the "
                                 "triangles in order)");
    next += mesh.triangle_count;
    if (next > scene.triangles.size())
      throw InputError(what, "its triangles run past the scene's " + std::to_string(scene.triangles.size()));
    if (uint64_t(mesh.first_vertex) + mesh.vertex_count > scene.vertices.size())
      throw InputError(what, "its vertices run past the scene's " + std::to_string(scene.vertices.size()));
  }
  if (next != scene.triangles.size())
    throw InputError(where, "its meshes cover " + std::to_string(next) + " of its " +
                                std::to_string(scene.triangles.size()) + " triangles");
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& instance = scene.instances[i];
    const std::string what = where + " instance " + std::to_string(i);
    if (instance.mesh >= scene.meshes.size())
      throw InputError(what, "places mesh " + std::to_string(instance.mesh) + ", which does not exist (" +
                                 std::to_string(scene.meshes.size()) + " meshes)");
    if (const std::string problem = instance_transform_problem(instance.object_to_world); !problem.empty())
      throw InputError(what + " (mesh '" + scene.meshes[instance.mesh].name + "')", problem);
  }
}
}  // namespace

void validate_scene(Scene& scene) {
  const std::string where = "scene '" + scene.name + "'";
  if (scene.materials.empty()) scene.materials.push_back(Material{});
  if (scene.material_ids.empty()) scene.material_ids.assign(scene.triangles.size(), 0);
  if (scene.material_ids.size() != scene.triangles.size())
    throw InputError(where, "material id count " + std::to_string(scene.material_ids.size()) +
                                " differs from triangle count " +
                                std::to_string(scene.triangles.size()));
  const bool has_uvs = !scene.triangle_uvs.empty();
  if (has_uvs && scene.triangle_uvs.size() != scene.triangles.size())
    throw InputError(where, "texture coordinate count " + std::to_string(scene.triangle_uvs.size()) +
                                " differs from triangle count " + std::to_string(scene.triangles.size()));

  const bool instanced = !scene.instances.empty() || !scene.meshes.empty();
  if (instanced) check_instancing(scene, where);

  ValidationReport report;
  report.input_triangles = scene.triangles.size();  // instanced: the unique (object-space) triangles
  // What the loader left out before triangles existed: kept, the loader counted them.
  report.dropped_sky_faces = scene.validation.dropped_sky_faces;
  report.dropped_tool_faces = scene.validation.dropped_tool_faces;
  // Per vertex: 1 usable, 0 non-finite, 2 finite but beyond kMaxSceneCoordinate.
  std::vector<char> vertex_finite(scene.vertices.size());
  for (size_t i = 0; i < scene.vertices.size(); ++i) {
    const vec3& v = scene.vertices[i];
    const bool finite = is_finite(v);
    const bool in_range = std::fabs(v.x) <= kMaxSceneCoordinate &&
                          std::fabs(v.y) <= kMaxSceneCoordinate && std::fabs(v.z) <= kMaxSceneCoordinate;
    vertex_finite[i] = !finite ? 0 : in_range ? 1 : 2;
    report.non_finite_vertices += !finite;
  }

  // The triangle ranges checked, each with the vertices its indices may name: every
  // mesh of an instanced scene (its own vertices only), or the whole flat scene.
  struct Range {
    size_t first, count;
    uint64_t lo, hi;
    SceneMesh* mesh;
  };
  std::vector<Range> ranges;
  if (instanced) {
    for (SceneMesh& m : scene.meshes)
      ranges.push_back({m.first_triangle, m.triangle_count, m.first_vertex, uint64_t(m.first_vertex) + m.vertex_count, &m});
  } else {
    ranges.push_back({0, scene.triangles.size(), 0, scene.vertices.size(), nullptr});
  }
  size_t kept = 0;
  for (const Range& r : ranges) {
    const size_t kept_before = kept;
    for (size_t i = r.first; i < r.first + r.count; ++i) {
      const uvec3 t = scene.triangles[i];
      if (t.x < r.lo || t.y < r.lo || t.z < r.lo || t.x >= r.hi || t.y >= r.hi || t.z >= r.hi) {
        ++report.dropped_bad_index;
        continue;
      }
      if (!vertex_finite[t.x] || !vertex_finite[t.y] || !vertex_finite[t.z]) {
        ++report.dropped_non_finite;
        continue;
      }
      if (vertex_finite[t.x] == 2 || vertex_finite[t.y] == 2 || vertex_finite[t.z] == 2) {
        ++report.dropped_out_of_range;
        continue;
      }
      uint32_t material = scene.material_ids[i];
      if (material >= scene.materials.size())
        throw InputError(where, "triangle " + std::to_string(i) + " has material id " +
                                    std::to_string(material) + " but only " +
                                    std::to_string(scene.materials.size()) + " materials exist");
      if (zero_area(scene.vertices[t.x], scene.vertices[t.y], scene.vertices[t.z]))
        ++report.degenerate_kept;
      scene.triangles[kept] = t;
      scene.material_ids[kept] = material;
      if (has_uvs) scene.triangle_uvs[kept] = scene.triangle_uvs[i];
      ++kept;
    }
    if (r.mesh) {  // the mesh keeps its surviving triangles, now from kept_before
      r.mesh->first_triangle = uint32_t(kept_before);
      r.mesh->triangle_count = uint32_t(kept - kept_before);
    }
  }
  scene.triangles.resize(kept);
  scene.material_ids.resize(kept);
  if (has_uvs) scene.triangle_uvs.resize(kept);
  scene.validation = report;

  if (scene.triangles.empty())
    throw InputError(where, "no valid triangle (" + std::to_string(report.input_triangles) +
                                " in the input, all dropped or none given)");
  if (instanced) {
    // Object coordinates are checked above; a transform may still carry a mesh past
    // the range (the flat form drops those triangles; one instance cannot be split).
    const Aabb world = scene.bounds();
    const auto beyond = [](const Aabb& box) {
      return !box.empty() && !(glm::all(glm::lessThanEqual(glm::abs(box.lo), vec3(kMaxSceneCoordinate))) &&
                               glm::all(glm::lessThanEqual(glm::abs(box.hi), vec3(kMaxSceneCoordinate))));
    };
    if (beyond(world))
      for (uint32_t i = 0; i < scene.instances.size(); ++i)
        if (beyond(scene.instance_bounds(i)))
          throw InputError(where + " instance " + std::to_string(i) + " (mesh '" +
                               scene.meshes[scene.instances[i].mesh].name + "')",
                           "places its mesh beyond +-1e18 (kMaxSceneCoordinate), past Embree's range");
  }
  for (const Material& m : scene.materials) {
    const float values[] = {m.albedo.x, m.albedo.y, m.albedo.z, m.reflectance, m.transmittance,
                            m.ior};
    for (float v : values)
      if (!std::isfinite(v) || v < 0.0f)
        throw InputError(where + " material '" + m.name + "'",
                         "albedo, reflectance, transmittance and ior must be finite and >= 0");
    if (m.alpha_texture >= int64_t(scene.alpha_textures.size()) || m.alpha_texture < -1)
      throw InputError(where + " material '" + m.name + "'",
                       "alpha texture " + std::to_string(m.alpha_texture) + " does not exist (" +
                           std::to_string(scene.alpha_textures.size()) + " alpha textures)");
    if (m.alpha_tested() && !(m.alpha_cutoff >= 0.0f && m.alpha_cutoff <= 1.0f))
      throw InputError(where + " material '" + m.name + "' alpha_cutoff", "must lie in [0, 1]");
  }
  for (const AlphaTexture& t : scene.alpha_textures)
    if (t.width == 0 || t.height == 0 || t.alpha.size() != size_t(t.width) * t.height)
      throw InputError(where + " alpha texture '" + t.file + "'",
                       "is " + std::to_string(t.width) + " x " + std::to_string(t.height) + " with " +
                           std::to_string(t.alpha.size()) + " texels");
  if (!scene.alpha_textures.empty() && !has_uvs)
    throw InputError(where, "has alpha-tested materials but no texture coordinates");
  // Coordinates only matter where a texture is sampled; a non-finite one samples texel 0.
  for (const Camera& c : scene.cameras) {
    if (!is_finite(c.position) || !is_finite(c.target) || !is_finite(c.up) ||
        c.position == c.target || !(c.vertical_fov_deg > 0.0f && c.vertical_fov_deg < 180.0f))
      throw InputError(where + " camera '" + c.name + "'",
                       "position/target/up must be finite, target != position, 0 < fov < 180");
  }
  if (!(scene.ao.cutoff_relative > 0.0f) || !std::isfinite(scene.ao.cutoff_relative))
    throw InputError(where + " ao.cutoff", "must be a finite number > 0");
}

}  // namespace rtsim
