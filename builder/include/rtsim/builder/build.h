#pragma once
// The one entry point to every BVH builder, selected by name from the registry
// (builder_registry.h), which also describes every field below as a parameter.
#include <rtsim/builder/bvh.h>
#include <rtsim/builder/node_format.h>
#include <rtsim/builder/validate_bvh.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

struct BuildParams {
  std::string builder = "sah";  // a name in builder_registry()
  float t1 = 1.0f;              // cost of one ray-node test
  float t2 = 1.0f;              // cost of one ray-triangle test
  uint32_t max_leaf_size = 4;   // must fit the hardware leaf count field
  // Children per node of the tree returned: 2 = the builder's binary tree; 4, 6
  // or 8 = that tree collapsed (collapse.h) with the builder's own cost model.
  // The Embree builders build wide trees themselves (maxBranchingFactor).
  uint32_t width = 2;
  uint32_t max_depth = 64;
  uint32_t bins = 32;           // binned SAH; 0 = full sweep
  uint64_t seed = 1;
  uint32_t threads = 0;         // 0 = all cores; never changes the tree
  // sbvh
  float sbvh_alpha = 1e-5f;
  uint32_t sbvh_min_depth = 0;         // spatial splits only at depth >= this (osah: its visibility depth)
  float sbvh_reference_budget = 2.0f;  // x N triangles (Embree's embree-sbvh capacity: 2 x N)
  uint32_t sbvh_split_limit = 7;       // times one reference may be split (0..7)
  uint32_t treelet_passes = 2;         // sbvh: treelet restructuring passes after the build (docs/build-speed.md)
  uint32_t treelet_leaves = 7;         // leaves per restructured treelet (3..8)
  // osah (Vinkler, Havran and Sochor 2012, the authors' rules; builders/osah.cpp):
  // in mixed nodes (0 < visible < all) at depth < floor(osah_depth x log2 N), a
  // visibility split with P_i = osah_w * V_i / V + (1 - osah_w) * A_i / A over
  // spatial bins (osah_spatial off: over object bins, weight osah_w * (1 - V/N)),
  // taken when the child holding fewer visible triangles has more references than
  // the larger child of the best plain split (osah_acceptance "authors"; "always":
  // whenever one exists); SBVH below that depth in nodes holding visible
  // triangles, object splits elsewhere; osah_child_order "visible-first" puts the
  // child with more visible references first ("split": the split's order).
  // Visibility: primary rays through the pixel centres of an osah_width x
  // osah_height image from `camera`, and osah_ao_rays AO rays from each hit (the
  // scene's AO length, ao_cutoff_relative; none when the scene has AO off), seeded
  // by `seed`.
  std::string camera = "view1";
  float osah_w = 0.9f;
  uint32_t osah_width = 256, osah_height = 256;
  uint32_t osah_ao_rays = 4;
  float osah_depth = 0.5f;
  std::string osah_acceptance = "authors";
  bool osah_spatial = true;
  std::string osah_child_order = "visible-first";
  // aobvh
  // K AO rays per estimate, shared by up to ao_share nearby triangles (occlusion.h).
  // The default, 4 rays per triangle with no sharing (the patent's per-triangle
  // estimate), is the measured trade-off of docs/builders.md ("AO-BVH's sampling"):
  // with sharing, interior's tree moved by +-3-5% ops/ray with the builder seed; per
  // triangle its spread is +-0.2% for a 3-5x dearer AO pass on the large scenes.
  uint32_t ao_rays = 4;
  uint32_t ao_share = 1;
  float ao_cutoff_relative = -1;  // < 0: the scene's ao.cutoff_relative
  float ao_weight_floor = 0.05f;  // w = floor + (1 - floor) * occlusion value
  // true: weights scaled to mean 1 (T2 keeps meaning one average triangle test;
  // equal values give exactly the SAH tree). false: the patent's literal cost,
  // AO(S) = the plain sum of the (floored) values in place of the count, with
  // the same T2 - triangle tests in occluded regions become cheap relative to
  // the 2*T1 node tests. See occlusion_weights().
  bool ao_normalise = true;
  bool ao_both_sides = false;
  // rdh (ray-distribution heuristic): sample rays cast before the build (see
  // ray_samples.h) - rdh_resolution^2 primary rays per camera and rdh_ao_rays AO
  // rays per primary hit; P_i = (A_i / A + n_i / k) / (1 + n / k) with k = rdh_prior.
  // rdh_cameras: "camera" = `camera` only (the one the workload traces), "all" =
  // every camera of the scene. rdh_resolution 0 = no sample rays (the SAH tree).
  // rdh-sbvh: the same with SBVH's spatial splits (sbvh_* parameters).
  uint32_t rdh_resolution = 64;
  uint32_t rdh_ao_rays = 4;
  float rdh_prior = 8.0f;
  std::string rdh_cameras = "camera";
  // Per-triangle values supplied by the caller instead of casting rays (tests,
  // cached estimates). Empty = estimate with Embree. NaN / infinite / negative
  // entries are sanitised (occlusion: treated as 1 = fully open; counted in
  // BuildReport::sanitised_values).
  std::vector<float> occlusion_values;   // aobvh, in [0, 1]
  std::vector<uint8_t> visibility;       // osah, 0 / 1
};

// Everything the quality report shows, filled by the builder that ran.
struct BuildReport {
  std::string builder;
  double order_seconds = 0;     // sorting the triangles into geometric order (build_bvh)
  double estimate_seconds = 0;  // visibility / AO estimation
  double build_seconds = 0;     // tree construction
  uint64_t peak_memory_bytes = 0;
  std::vector<float> weights;   // per-triangle weights the builder used (empty for sah/median)
  std::vector<uint8_t> visibility;  // osah: per-triangle visibility from the camera
  uint64_t references = 0;      // prim_refs (> N only with spatial splits)
  // Nodes of the builder's own tree whose children share a triangle: the spatial
  // splits that duplicated references (count_spatial_splits; 0 for builders that do
  // not split references), read off the tree alike for ours and Embree's.
  uint64_t spatial_splits = 0;
  uint64_t treelets_restructured = 0;  // sbvh: treelets rebuilt after the build (all passes)
  uint64_t forced_splits = 0;   // nodes over max_leaf_size split although a leaf was cheaper
  uint64_t median_splits = 0;   // fallback median splits (no usable SAH split / depth limit)
  uint64_t sanitised_values = 0;  // NaN/invalid weights or occlusion values replaced by 1
  uint64_t visible_triangles = 0;  // osah
  uint32_t visibility_depth = 0;   // osah: the visibility split is tried above this depth
  uint64_t visibility_splits = 0;  // osah: nodes given the visibility split
  double mean_occlusion = 0;    // aobvh: mean occlusion value (1 = open)
  uint64_t ao_rays = 0;         // aobvh: rays cast
  uint64_t rdh_rays = 0;        // rdh: sample rays cast (primary + AO)
  double collapse_seconds = 0;  // width > 2: the collapse pass (not in build_seconds)
  uint64_t binary_nodes = 0;    // width > 2: nodes of the binary tree collapsed (0 = none)
  // Two-level trees (instanced scenes): the TLAS's build, and (aobvh) the mean
  // absolute difference between a placement's occlusion and its triangle's mean
  // over placements, which the shared BLAS is built with.
  double tlas_seconds = 0;
  double placement_spread = 0;
};

// Limits a tree from `params` must satisfy (for validate_bvh).
BvhLimits limits_for(const BuildParams& params);

// Throws InputError for unknown builders, bad parameters or an empty scene. An
// instanced scene (Scene::instanced) gets a two-level tree (Bvh::two_level):
// the builder's tree per mesh and an SAH TLAS over the instances (two_level.cpp).
Bvh build_bvh(const Scene& scene, const BuildParams& params, BuildReport* report = nullptr);
// What build_bvh checks first: InputError naming the BuildParams field (e.g.
// "sbvh_reference_budget") for a value out of the range builder_parameters() gives.
// The command line calls it right after parsing and names the flag instead.
void check_build_params(const BuildParams& params);
std::vector<std::string> builder_names();

// Builds for a node format: its width (2 for bvh2-*: the builder's own tree) and
// leaves no larger than the format holds (max_leaf_size lowered to it if larger).
void apply_node_format(BuildParams& params, const NodeFormat& format);

}  // namespace rtsim
