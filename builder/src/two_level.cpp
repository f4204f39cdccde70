// Two-level trees for instanced scenes (Bvh::two_level, bvh.h): a BLAS per mesh by
// the named builder, over the mesh's object-space triangles, and a TLAS over the
// instances' world boxes by our SAH core, one instance per leaf. For AO-BVH (both
// readings) the TLAS is occlusion-weighted too: each instance is a primitive
// weighted by the mean occlusion of its placed triangles, with object splits only
// (an instance box cannot be clipped). OSAH's TLAS stays SAH: its rules are
// spatial splits over visible triangles, which instance boxes are not.
//
// Builders whose per-triangle inputs come from rays (AO-BVH's occlusion, OSAH's
// visibility) get them in world space, on the flattened scene: each placement of a
// triangle has its own value, and the BLAS, shared by every placement, is built
// with one value per triangle - the mean occlusion over its placements, and
// "visible" if any placement is. BuildReport::placement_spread says how far the
// placements' occlusion lies from that mean. RDH's sample rays are segments through
// world space, which a BLAS in object space cannot weigh: rdh refuses instances.
#include <rtsim/builder/build.h>
#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/occlusion.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/error.h>

#include "builders/builders.h"
#include "two_level.h"

#include <chrono>
#include <cmath>

namespace rtsim::detail {

namespace {
// Mesh m alone, in object space, its triangles renumbered from 0.
Scene mesh_scene(const Scene& scene, const SceneMesh& mesh) {
  Scene out;
  out.name = scene.name + ":" + mesh.name;
  out.vertices.assign(scene.vertices.begin() + mesh.first_vertex,
                      scene.vertices.begin() + mesh.first_vertex + mesh.vertex_count);
  out.triangles.reserve(mesh.triangle_count);
  for (uint32_t t = mesh.first_triangle; t < mesh.first_triangle + mesh.triangle_count; ++t)
    out.triangles.push_back(scene.triangles[t] - uvec3(mesh.first_vertex));
  out.material_ids.assign(scene.material_ids.begin() + mesh.first_triangle,
                          scene.material_ids.begin() + mesh.first_triangle + mesh.triangle_count);
  out.materials = scene.materials;
  out.cameras = scene.cameras;
  out.ao = scene.ao;
  return out;
}

// The flattened scene's first triangle of each instance (flatten's order).
std::vector<uint64_t> flat_offsets(const Scene& scene) {
  std::vector<uint64_t> offsets(scene.instances.size());
  uint64_t at = 0;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    offsets[i] = at;
    at += scene.meshes[scene.instances[i].mesh].triangle_count;
  }
  return offsets;
}

// Appends `part` to `out`, its node and prim_ref indices shifted; returns its root.
uint32_t append_tree(Bvh& out, const Bvh& part, uint32_t prim_offset) {
  const uint32_t node_base = uint32_t(out.nodes.size()), ref_base = uint32_t(out.prim_refs.size());
  for (BvhNode n : part.nodes) {
    n.index += n.is_leaf() ? ref_base : node_base;
    out.nodes.push_back(n);
  }
  for (uint32_t p : part.prim_refs) out.prim_refs.push_back(p + prim_offset);
  return node_base;
}
}  // namespace

Bvh build_two_level(const Scene& scene, const BuildParams& params, BuildReport& r) {
  if (!builder_info(params.builder).builds_blas)
    throw InputError("builder", "'" + params.builder +
                                    "' weighs world-space sample rays, which a BLAS in object space cannot; "
                                    "build the flat scene (leave out --instanced) or pick another builder");
  const auto estimate_start = std::chrono::steady_clock::now();
  const size_t unique = scene.triangle_count();
  std::vector<float> occlusion = params.occlusion_values;
  std::vector<uint8_t> visibility = params.visibility;
  std::vector<double> instance_occlusion(scene.instances.size(), 0.0);  // AO-BVH's TLAS weights: the placed mean
  const bool wants_occlusion = params.builder == "aobvh" || params.builder == "aosbvh";
  const bool wants_visibility = params.builder == "osah";
  if ((wants_occlusion && occlusion.empty()) || (wants_visibility && visibility.empty())) {
    // Each placement in world space, on the flat scene; then one value per triangle.
    const Scene flat = flatten(scene);
    const std::vector<uint64_t> offsets = flat_offsets(scene);
    builders::with_threads(params.threads, [&] {
      if (wants_occlusion) {
        OcclusionParams ao;
        ao.rays = params.ao_rays;
        ao.share = params.ao_share;
        ao.cutoff = builders::ao_cutoff(flat, params);
        ao.both_sides = params.ao_both_sides;
        ao.seed = params.seed;
        EmbreeScene embree(flat, EmbreeScene::Quality::fast);
        const std::vector<float> placed = estimate_occlusion(flat, embree, ao, &r.ao_rays);
        std::vector<double> sum(unique, 0.0);
        std::vector<uint32_t> placements(unique, 0);
        for (size_t i = 0; i < scene.instances.size(); ++i) {
          const SceneMesh& m = scene.meshes[scene.instances[i].mesh];
          for (uint32_t k = 0; k < m.triangle_count; ++k) {
            const float v = placed[offsets[i] + k];
            sum[m.first_triangle + k] += usable_occlusion(v);
            ++placements[m.first_triangle + k];
          }
        }
        occlusion.assign(unique, 1.0f);  // a triangle no instance places: open
        for (size_t t = 0; t < unique; ++t)
          if (placements[t]) occlusion[t] = float(sum[t] / placements[t]);
        double spread = 0;
        for (size_t i = 0; i < scene.instances.size(); ++i) {
          const SceneMesh& m = scene.meshes[scene.instances[i].mesh];
          for (uint32_t k = 0; k < m.triangle_count; ++k) {
            const float v = placed[offsets[i] + k];
            spread += std::fabs(usable_occlusion(v) - occlusion[m.first_triangle + k]);
            instance_occlusion[i] += usable_occlusion(v);
          }
          if (m.triangle_count) instance_occlusion[i] /= m.triangle_count;
        }
        r.placement_spread = placed.empty() ? 0 : spread / double(placed.size());
      }
      if (wants_visibility) {
        VisibilityParams vp;
        vp.width = params.osah_width;
        vp.height = params.osah_height;
        vp.ao_rays = flat.ao.enabled ? params.osah_ao_rays : 0;
        vp.ao_cutoff = builders::ao_cutoff(flat, params);
        vp.seed = params.seed;
        EmbreeScene embree(flat);
        const std::vector<uint8_t> placed = estimate_visibility(flat, embree, flat.camera(params.camera), vp);
        visibility.assign(unique, 0);
        for (size_t i = 0; i < scene.instances.size(); ++i) {
          const SceneMesh& m = scene.meshes[scene.instances[i].mesh];
          for (uint32_t k = 0; k < m.triangle_count; ++k) visibility[m.first_triangle + k] |= placed[offsets[i] + k];
        }
      }
    });
  }
  if (wants_occlusion && !params.occlusion_values.empty()) {
    // Supplied per unique triangle: an instance's value is its mesh's mean.
    for (size_t i = 0; i < scene.instances.size(); ++i) {
      const SceneMesh& m = scene.meshes[scene.instances[i].mesh];
      instance_occlusion[i] = 0;
      for (uint32_t k = 0; k < m.triangle_count; ++k) instance_occlusion[i] += usable_occlusion(occlusion[m.first_triangle + k]);
      if (m.triangle_count) instance_occlusion[i] /= m.triangle_count;
    }
  }
  r.estimate_seconds = builders::seconds_since(estimate_start);

  // The BLASes, one per mesh, by the named builder.
  std::vector<Bvh> blas(scene.meshes.size());
  r.weights.assign(wants_occlusion ? unique : 0, 1.0f);
  r.visibility.assign(wants_visibility ? unique : 0, 0);
  double occlusion_sum = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const SceneMesh& mesh = scene.meshes[m];
    if (mesh.triangle_count == 0) continue;
    const Scene part = mesh_scene(scene, mesh);
    BuildParams part_params = params;
    const auto slice = [&](const auto& values) {
      using V = std::decay_t<decltype(values)>;
      return values.empty() ? V{} : V(values.begin() + mesh.first_triangle,
                                      values.begin() + mesh.first_triangle + mesh.triangle_count);
    };
    part_params.occlusion_values = slice(occlusion);
    part_params.visibility = slice(visibility);
    BuildReport part_report;
    blas[m] = build_bvh(part, part_params, &part_report);
    r.build_seconds += part_report.build_seconds;
    r.collapse_seconds += part_report.collapse_seconds;
    r.order_seconds += part_report.order_seconds;
    r.references += part_report.references;
    r.spatial_splits += part_report.spatial_splits;
    r.treelets_restructured += part_report.treelets_restructured;
    r.forced_splits += part_report.forced_splits;
    r.median_splits += part_report.median_splits;
    r.sanitised_values += part_report.sanitised_values;
    r.visible_triangles += part_report.visible_triangles;
    r.visibility_splits += part_report.visibility_splits;
    r.visibility_depth = std::max(r.visibility_depth, part_report.visibility_depth);
    r.binary_nodes += part_report.binary_nodes;
    r.peak_memory_bytes = std::max(r.peak_memory_bytes, part_report.peak_memory_bytes);
    occlusion_sum += part_report.mean_occlusion * mesh.triangle_count;
    for (size_t k = 0; k < part_report.weights.size() && k < mesh.triangle_count; ++k)
      r.weights[mesh.first_triangle + k] = part_report.weights[k];
    for (size_t k = 0; k < part_report.visibility.size() && k < mesh.triangle_count; ++k)
      r.visibility[mesh.first_triangle + k] = part_report.visibility[k];
  }
  if (wants_occlusion) r.mean_occlusion = occlusion_sum / double(unique);

  // The TLAS: SAH over the placed instances' world boxes, each given to the core as
  // a triangle whose bounds are the box (two opposite corners and a third), one per leaf.
  Scene boxes;
  boxes.name = scene.name + ":instances";
  std::vector<uint32_t> instance_of;
  for (uint32_t i = 0; i < scene.instances.size(); ++i) {
    if (scene.meshes[scene.instances[i].mesh].triangle_count == 0) continue;
    const Aabb b = scene.instance_bounds(i);
    const uint32_t v = uint32_t(boxes.vertices.size());
    boxes.vertices.push_back(b.lo);
    boxes.vertices.push_back(b.hi);
    boxes.vertices.push_back(vec3(b.lo.x, b.hi.y, b.lo.z));
    boxes.triangles.push_back(uvec3(v, v + 1, v + 2));
    boxes.material_ids.push_back(0);
    instance_of.push_back(i);
  }
  boxes.materials.push_back(Material{});
  if (instance_of.empty()) throw InputError("scene '" + scene.name + "'", "no instance places any triangles");
  BuildParams tlas_params;
  tlas_params.builder = wants_occlusion ? "aobvh" : "sah";
  if (wants_occlusion) {
    for (uint32_t i : instance_of) tlas_params.occlusion_values.push_back(float(instance_occlusion[i]));
    tlas_params.ao_weight_floor = params.ao_weight_floor;
    tlas_params.ao_normalise = params.ao_normalise;
  }
  tlas_params.t1 = params.t1;
  tlas_params.t2 = params.t2;
  tlas_params.width = params.width;
  tlas_params.max_leaf_size = 1;
  tlas_params.max_depth = params.max_depth;
  tlas_params.bins = params.bins;
  tlas_params.threads = params.threads;
  const auto tlas_start = std::chrono::steady_clock::now();
  Bvh tlas = build_bvh(boxes, tlas_params);
  for (uint32_t& p : tlas.prim_refs) p = instance_of[p];
  r.tlas_seconds = builders::seconds_since(tlas_start);

  Bvh out = std::move(tlas);
  out.tlas_nodes = uint32_t(out.nodes.size());
  out.blas_roots.assign(scene.meshes.size(), Bvh::kNoBlas);
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    if (!blas[m].empty()) out.blas_roots[m] = append_tree(out, blas[m], scene.meshes[m].first_triangle);
  return out;
}

}  // namespace rtsim::detail
