// build_bvh: the builders by name. sah, sbvh, osah and aobvh are policies over the
// one weighted-SAH core; median and the two Embree builders stand apart.
#include <rtsim/builder/build.h>
#include <rtsim/builder/collapse.h>
#include <rtsim/builder/occlusion.h>
#include <rtsim/builder/ray_samples.h>
#include <rtsim/workloads/embree_scene.h>
#include <rtsim/workloads/error.h>

#include "embree_builder.h"
#include "median_builder.h"
#include "weighted_sah_core.h"

#include <tbb/task_arena.h>

#include <chrono>
#include <cmath>

namespace rtsim {

namespace {
double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}


detail::CoreConfig core_config(const BuildParams& p) {
  detail::CoreConfig c;
  c.t1 = p.t1;
  c.t2 = p.t2;
  c.max_leaf_size = p.max_leaf_size;
  c.max_depth = p.max_depth;
  c.bins = p.bins;
  c.threads = p.threads;
  c.osah_w = p.osah_w;
  c.sbvh_alpha = p.sbvh_alpha;
  c.reference_budget = p.sbvh_reference_budget;
  c.split_limit = p.sbvh_split_limit;
  return c;
}

void copy_stats(const detail::CoreStats& s, BuildReport* report) {
  report->references = s.references;
  report->spatial_splits = s.spatial_splits;
  report->forced_splits = s.forced_splits;
  report->median_splits = s.median_splits;
  report->peak_memory_bytes = std::max<uint64_t>(report->peak_memory_bytes, s.working_bytes);
}

// Runs fn inside an arena of the requested size (0 = all cores).
template <class F>
void with_threads(uint32_t threads, F&& fn) {
  if (threads == 0) {
    fn();
  } else {
    tbb::task_arena arena{int(threads)};
    arena.execute(fn);
  }
}
}  // namespace

std::vector<std::string> builder_names() {
  return {"sah", "median", "sbvh", "osah", "aobvh", "aosbvh", "rdh", "embree", "embree-sbvh"};
}

void apply_node_format(BuildParams& params, const NodeFormat& format) {
  params.width = format.encoding == BoxEncoding::OwnBoxFp32 ? 2 : format.width;
  params.max_leaf_size = std::min(params.max_leaf_size, format.max_leaf_triangles);
}

BvhLimits limits_for(const BuildParams& params) {
  BvhLimits limits;
  limits.max_leaf_size = params.max_leaf_size;
  limits.max_depth = params.max_depth;
  limits.max_width = params.width;
  limits.split_references =
      params.builder == "sbvh" || params.builder == "aosbvh" || params.builder == "embree-sbvh" ||
      (params.builder == "rdh" && params.rdh_spatial_splits);
  // embree-sbvh fills up to ~2 x N references (its capacity); ours keeps the budget.
  limits.reference_budget = params.builder == "embree-sbvh" ? 2.0 : params.sbvh_reference_budget;
  return limits;
}

void check_build_params(const BuildParams& p) {
  auto positive = [](float v) { return std::isfinite(v) && v > 0; };
  if (!positive(p.t1)) throw InputError("t1", "must be a positive finite number");
  if (!positive(p.t2)) throw InputError("t2", "must be a positive finite number");
  if (p.max_leaf_size == 0) throw InputError("max_leaf_size", "must be at least 1");
  if (p.max_depth == 0) throw InputError("max_depth", "must be at least 1");
  if (p.width < 2 || p.width > kMaxBvhWidth)
    throw InputError("width", "must be 2.." + std::to_string(kMaxBvhWidth) + " children per node");
  if (p.bins == 1 || p.bins > 256) throw InputError("bins", "must be 0 (full sweep) or 2..256");
  if (!std::isfinite(p.sbvh_alpha) || p.sbvh_alpha < 0)
    throw InputError("sbvh_alpha", "must be >= 0");
  if (!std::isfinite(p.sbvh_reference_budget) || p.sbvh_reference_budget < 1)
    throw InputError("sbvh_reference_budget", "must be >= 1");
  if (p.sbvh_split_limit > 7) throw InputError("sbvh_split_limit", "must be 0..7");
  if (!std::isfinite(p.osah_w) || p.osah_w < 0 || p.osah_w > 1)
    throw InputError("osah_w", "must be in [0, 1]");
  if (p.osah_width == 0 || p.osah_height == 0)
    throw InputError("osah_width/osah_height", "must be at least 1");
  if (!std::isfinite(p.ao_weight_floor) || p.ao_weight_floor < 0 || p.ao_weight_floor > 1)
    throw InputError("ao_weight_floor", "must be in [0, 1]");
  if (!std::isfinite(p.ao_cutoff_relative)) throw InputError("ao_cutoff_relative", "must be finite");
  if (p.rdh_resolution > 4096) throw InputError("rdh_resolution", "must be 0..4096 rays per side");
  if (p.rdh_ao_rays > 256) throw InputError("rdh_ao_rays", "must be 0..256 per primary hit");
  if (!positive(p.rdh_prior)) throw InputError("rdh_prior", "must be a positive finite number");
  if (p.rdh_cameras != "camera" && p.rdh_cameras != "all")
    throw InputError("rdh_cameras", "must be 'camera' or 'all'");
}

namespace {
Bvh build_binary_or_embree(const Scene& scene, const BuildParams& params, BuildReport* report);
}

Bvh build_bvh(const Scene& scene, const BuildParams& params, BuildReport* report) {
  BuildReport local;
  BuildReport& r = report ? *report : local;
  Bvh bvh = build_binary_or_embree(scene, params, &r);
  if (params.width == 2 || params.builder == "embree" || params.builder == "embree-sbvh")
    return bvh;
  CollapseParams cp;
  cp.width = params.width;
  cp.max_leaf_size = params.max_leaf_size;
  cp.t1 = params.t1;
  cp.t2 = params.t2;
  cp.weights = r.weights;
  cp.visibility = r.visibility;
  cp.osah_w = params.osah_w;
  const auto start = std::chrono::steady_clock::now();
  r.binary_nodes = bvh.nodes.size();
  bvh = collapse_bvh(bvh, cp);
  r.collapse_seconds = seconds_since(start);
  return bvh;
}

namespace {
Bvh build_binary_or_embree(const Scene& scene, const BuildParams& params, BuildReport* report) {
  check_build_params(params);
  BuildReport& r = *report;
  r = BuildReport{};
  r.builder = params.builder;
  const size_t n = scene.triangle_count();
  if (n == 0) throw InputError("scene '" + scene.name + "'", "has no triangles to build a BVH over");
  if (detail::levels_needed(n, params.max_leaf_size) > params.max_depth)
    throw InputError("max_depth", "too small for " + std::to_string(n) +
                                      " triangles with max_leaf_size " +
                                      std::to_string(params.max_leaf_size));
  const std::string& name = params.builder;
  detail::CoreConfig config = core_config(params);
  detail::CoreStats stats;
  Bvh bvh;

  if (name == "sah" || name == "sbvh") {
    config.spatial_splits = name == "sbvh";
    const auto start = std::chrono::steady_clock::now();
    bvh = detail::build_weighted_sah(scene, config, &stats);
    r.build_seconds = seconds_since(start);
    copy_stats(stats, &r);
  } else if (name == "osah") {
    const auto start = std::chrono::steady_clock::now();
    if (!params.visibility.empty()) {
      if (params.visibility.size() != n)
        throw InputError("visibility", "expected " + std::to_string(n) + " entries, got " +
                                           std::to_string(params.visibility.size()));
      r.visibility.resize(n);
      for (size_t i = 0; i < n; ++i) r.visibility[i] = params.visibility[i] ? 1 : 0;
    } else {
      const Camera& camera = scene.camera(params.camera);
      with_threads(params.threads, [&] {
        EmbreeScene embree(scene);
        r.visibility =
            estimate_visibility(scene, embree, camera, params.osah_width, params.osah_height);
      });
    }
    for (uint8_t v : r.visibility) r.visible_triangles += v;
    r.estimate_seconds = seconds_since(start);
    config.visible = &r.visibility;
    const auto build_start = std::chrono::steady_clock::now();
    bvh = detail::build_weighted_sah(scene, config, &stats);
    r.build_seconds = seconds_since(build_start);
    copy_stats(stats, &r);
  } else if (name == "aobvh" || name == "aosbvh") {
    // aosbvh: the same occlusion weights with SBVH's spatial splits, to ask whether
    // the two reductions add up (the patent compares them, it does not combine them).
    config.spatial_splits = name == "aosbvh";
    const auto start = std::chrono::steady_clock::now();
    std::vector<float> values;
    if (!params.occlusion_values.empty()) {
      if (params.occlusion_values.size() != n)
        throw InputError("occlusion_values", "expected " + std::to_string(n) + " entries, got " +
                                                 std::to_string(params.occlusion_values.size()));
      values = params.occlusion_values;
    } else {
      OcclusionParams ao;
      ao.rays = params.ao_rays;
      const float relative =
          params.ao_cutoff_relative < 0 ? scene.ao.cutoff_relative : params.ao_cutoff_relative;
      ao.cutoff = relative * scene.diagonal();
      ao.both_sides = params.ao_both_sides;
      ao.seed = params.seed;
      with_threads(params.threads, [&] {
        EmbreeScene embree(scene);
        values = estimate_occlusion(scene, embree, ao);
      });
      r.ao_rays = uint64_t(n) * params.ao_rays;
    }
    r.weights =
        occlusion_weights(values, params.ao_weight_floor, &r.sanitised_values, params.ao_normalise);
    double sum = 0;
    for (float v : values) sum += std::isfinite(v) ? std::min(std::max(v, 0.0f), 1.0f) : 1.0f;
    r.mean_occlusion = sum / double(n);
    r.estimate_seconds = seconds_since(start);
    config.weights = &r.weights;
    const auto build_start = std::chrono::steady_clock::now();
    bvh = detail::build_weighted_sah(scene, config, &stats);
    r.build_seconds = seconds_since(build_start);
    copy_stats(stats, &r);
  } else if (name == "rdh") {
    const auto start = std::chrono::steady_clock::now();
    std::vector<const Camera*> cameras;
    if (params.rdh_cameras == "all") {
      for (const Camera& c : scene.cameras) cameras.push_back(&c);
    } else {
      cameras.push_back(&scene.camera(params.camera));
    }
    RaySampleParams sp;
    sp.resolution = params.rdh_resolution;
    sp.ao_rays = params.rdh_ao_rays;
    const float relative =
        params.ao_cutoff_relative < 0 ? scene.ao.cutoff_relative : params.ao_cutoff_relative;
    sp.ao_cutoff = relative * scene.diagonal();
    sp.seed = params.seed;
    RaySamples rays;
    if (sp.resolution > 0) {
      with_threads(params.threads, [&] {
        EmbreeScene embree(scene);
        rays = sample_rays(scene, embree, cameras, sp);
      });
    }
    r.rdh_rays = rays.size();
    r.estimate_seconds = seconds_since(start);
    config.rays = &rays;
    config.rdh_prior = params.rdh_prior;
    config.spatial_splits = params.rdh_spatial_splits;
    const auto build_start = std::chrono::steady_clock::now();
    bvh = detail::build_weighted_sah(scene, config, &stats);
    r.build_seconds = seconds_since(build_start);
    copy_stats(stats, &r);
    r.peak_memory_bytes += uint64_t(rays.size()) * 7 * sizeof(float);
  } else if (name == "median") {
    const auto start = std::chrono::steady_clock::now();
    bvh = detail::build_median(scene, params.max_leaf_size);
    r.build_seconds = seconds_since(start);
    r.references = bvh.prim_refs.size();
    r.peak_memory_bytes = bvh.nodes.capacity() * sizeof(BvhNode) + n * (4 + 12);
  } else if (name == "embree" || name == "embree-sbvh") {
    detail::EmbreeBuildConfig ec;
    ec.spatial_splits = name == "embree-sbvh";
    ec.t1 = params.t1;
    ec.t2 = params.t2;
    ec.max_leaf_size = params.max_leaf_size;
    ec.max_depth = params.max_depth;
    ec.threads = params.threads;
    ec.width = params.width;
    detail::EmbreeBuildStats es;
    const auto start = std::chrono::steady_clock::now();
    bvh = detail::build_with_embree(scene, ec, &es);
    r.build_seconds = seconds_since(start);
    r.references = bvh.prim_refs.size();
    r.peak_memory_bytes = es.working_bytes;
  } else {
    std::string names;
    for (const std::string& b : builder_names()) names += (names.empty() ? "" : ", ") + b;
    throw InputError("builder", "unknown builder '" + name + "' (known: " + names + ")");
  }
  return bvh;
}
}  // namespace

}  // namespace rtsim
