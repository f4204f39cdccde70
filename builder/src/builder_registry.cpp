// The two tables of builder_registry.h: the builders, and their parameters.
#include <rtsim/builder/builder_registry.h>
#include <rtsim/workloads/numbers.h>
#include <rtsim/workloads/error.h>

#include "builders/builders.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace rtsim {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
const std::vector<std::string> kSplitting = {"sbvh", "osah", "aosbvh", "rdh-sbvh"};
const std::vector<std::string> kOcclusion = {"aobvh", "aosbvh"};
const std::vector<std::string> kRayDistribution = {"rdh", "rdh-sbvh"};
}  // namespace

const std::vector<BuilderInfo>& builder_registry() {
  using namespace builders;
  static const std::vector<BuilderInfo> kBuilders = [] {
    std::vector<BuilderInfo> b;
    auto add = [&b](std::string name, std::string display, std::string summary,
                    Bvh (*build)(const Scene&, const BuildParams&, BuildReport&)) -> BuilderInfo& {
      BuilderInfo info;
      info.name = std::move(name);
      info.display_name = std::move(display);
      info.summary = std::move(summary);
      info.build = build;
      b.push_back(std::move(info));
      return b.back();
    };
    add("sah", "BVH (SAH)", "surface-area heuristic, binned (the weighted core, all weights 1)", build_sah);
    add("median", "BVH (median)", "object median on the longest axis", build_median);
    add("sbvh", "SBVH", "SAH with spatial splits and unsplitting", build_sbvh).splits_references = true;
    {
      BuilderInfo& i = add("osah", "OSAH",
                           "Vinkler et al.'s occlusion SAH: visibility splits in the upper levels of an SBVH",
                           build_osah);
      i.needs_camera = true;
      i.casts_rays = true;
      i.splits_references = true;
    }
    add("aobvh", "AO-BVH (object)",
        "SAH weighted by each triangle's AO openness (the patent, object-split reading)", build_aobvh)
        .casts_rays = true;
    {
      BuilderInfo& i = add("aosbvh", "AO-BVH (spatial)",
                           "AO-BVH weights with SBVH's spatial splits (the patent, sub-space reading)",
                           build_aosbvh);
      i.casts_rays = true;
      i.splits_references = true;
    }
    {
      BuilderInfo& i = add("rdh", "RDH", "SAH with the workload's own sampled ray fractions (Bittner and Havran)",
                           build_rdh);
      i.ours = true;
      i.needs_camera = true;
      i.casts_rays = true;
      i.builds_blas = false;
    }
    {
      BuilderInfo& i = add("rdh-sbvh", "RDH-SBVH", "rdh with SBVH's spatial splits", build_rdh_sbvh);
      i.ours = true;
      i.needs_camera = true;
      i.casts_rays = true;
      i.builds_blas = false;
      i.splits_references = true;
    }
    {
      BuilderInfo& i = add("embree", "Embree", "Embree rtcBuildBVH, medium quality (reference)", build_embree);
      i.ours = true;
      i.builds_wide = true;
    }
    {
      BuilderInfo& i = add("embree-sbvh", "Embree SBVH",
                           "Embree rtcBuildBVH, high quality with spatial splits (reference)",
                           build_embree_sbvh);
      i.ours = true;
      i.builds_wide = true;
      i.splits_references = true;
      i.fixed_reference_budget = 2.0;  // its primitive array capacity, 2 x N
    }
    return b;
  }();
  return kBuilders;
}

const BuilderInfo& builder_info(const std::string& name, const std::string& where) {
  for (const BuilderInfo& b : builder_registry())
    if (b.name == name) return b;
  std::string names;
  for (const BuilderInfo& b : builder_registry()) names += (names.empty() ? "" : ", ") + b.name;
  throw InputError(where, "unknown builder '" + name + "' (known: " + names + ")");
}

const std::vector<BuilderParameter>& builder_parameters() {
  static const std::vector<BuilderParameter> kParameters = [] {
    std::vector<BuilderParameter> t;
    auto add = [&t](std::string key, std::string flag, std::string unit, std::string description,
                    BuilderParameter::Field field, double min, double max,
                    std::vector<std::string> used_by = {}) -> BuilderParameter& {
      BuilderParameter p;
      p.key = std::move(key);
      p.flag = std::move(flag);
      p.unit = std::move(unit);
      p.description = std::move(description);
      p.field = field;
      p.min = min;
      p.max = max;
      p.used_by = std::move(used_by);
      t.push_back(std::move(p));
      return t.back();
    };
    using P = BuildParams;
    add("t1", "--t1", "cost", "cost of one ray-node test", &P::t1, 0, kInf).min_exclusive = true;
    add("t2", "--t2", "cost", "cost of one ray-triangle test", &P::t2, 0, kInf).min_exclusive = true;
    add("max_leaf_size", "--max-leaf-size", "triangles", "max triangles per leaf", &P::max_leaf_size, 1,
        kInf);
    add("max_depth", "--max-depth", "levels", "max leaf depth (root = 0)", &P::max_depth, 1, kInf);
    add("width", "", "children", "children per node (set by the node format)", &P::width, 2, kMaxBvhWidth);
    add("bins", "--bins", "bins", "SAH bins (0 = full sweep)", &P::bins, 0, 256);
    add("seed", "--build-seed", "", "seed of the builders' random choices (AO rays; default: --seed)",
        &P::seed, 0, kInf, {"osah", "aobvh", "aosbvh", "rdh", "rdh-sbvh"});
    add("threads", "--threads", "threads", "threads (0 = all); never changes the tree", &P::threads, 0,
        kInf)
        .in_tree_identity = false;
    add("sbvh_alpha", "--sbvh-alpha", "x root area", "sbvh: overlap threshold x root area", &P::sbvh_alpha,
        0, kInf, kSplitting);
    add("sbvh_min_depth", "--sbvh-min-depth", "levels", "sbvh: spatial splits only at depth >= this",
        &P::sbvh_min_depth, 0, 4096, {"sbvh", "aosbvh", "rdh-sbvh"});
    add("sbvh_reference_budget", "--sbvh-budget", "x triangles", "sbvh: references <= budget x N",
        &P::sbvh_reference_budget, 1, kInf, kSplitting);
    add("sbvh_split_limit", "--sbvh-split-limit", "splits", "sbvh: times one reference may be split",
        &P::sbvh_split_limit, 0, 7, kSplitting);
    add("treelet_passes", "--treelet-passes", "passes",
        "sbvh: bottom-up passes of treelet restructuring after the build (0 = none)", &P::treelet_passes, 0,
        16, {"sbvh", "aosbvh"});
    add("treelet_leaves", "--treelet-leaves", "leaves", "sbvh: leaves of each restructured treelet",
        &P::treelet_leaves, 3, 8, {"sbvh", "aosbvh"});
    add("camera", "", "", "the camera the tree is built for (the workload's)", &P::camera, 0, 0,
        {"osah", "rdh", "rdh-sbvh"});
    add("osah_w", "--osah-w", "", "osah: visibility weight w of the mixed probability", &P::osah_w, 0, 1,
        {"osah"});
    add("osah_width", "--osah-resolution", "pixels",
        "osah: visibility primary rays per side (width; the command line sets the height too)",
        &P::osah_width, 1, 16384, {"osah"});
    add("osah_height", "", "pixels", "osah: visibility primary rays, height", &P::osah_height, 1, 16384,
        {"osah"});
    add("osah_ao_rays", "--osah-ao-rays", "rays",
        "osah: AO rays per primary hit that also mark visibility (0: primary rays only)", &P::osah_ao_rays, 0,
        256, {"osah"});
    add("osah_depth", "--osah-depth", "x log2 N",
        "osah: the visibility split is tried at depth < floor(this x log2 triangles)", &P::osah_depth, 0, 64,
        {"osah"});
    add("osah_acceptance", "--osah-acceptance", "",
        "osah: authors = taken when its less-visible child has more references than the larger\n"
        "child of the best plain split; always = whenever one exists",
        &P::osah_acceptance, 0, 0, {"osah"})
        .choices = {"authors", "always"};
    add("osah_spatial", "--osah-spatial", "",
        "osah: on = spatial bins for the visibility split and SBVH below it (the authors'); off =\n"
        "object bins, weight w(1 - V/N), and no spatial splits", &P::osah_spatial, 0, 1, {"osah"});
    add("osah_child_order", "--osah-child-order", "",
        "osah: visible-first = the child with more visible references first;\nsplit = the split's order",
        &P::osah_child_order, 0, 0, {"osah"})
        .choices = {"visible-first", "split"};
    add("ao_rays", "--ao-rays", "rays", "aobvh: AO rays per estimate (K; per triangle with ao_share 1)",
        &P::ao_rays, 1, 65536, kOcclusion);
    add("ao_share", "--ao-share", "triangles",
        "aobvh: at most this many nearby, like-facing triangles share one K-ray estimate", &P::ao_share, 1,
        4096, kOcclusion);
    add("ao_cutoff_relative", "--ao-cutoff", "x scene diagonal",
        "aobvh, rdh: AO ray length x scene diagonal (< 0: the scene's setting, default 0.05)",
        &P::ao_cutoff_relative, -kInf, kInf, {"osah", "aobvh", "aosbvh", "rdh", "rdh-sbvh"});
    add("ao_weight_floor", "--ao-floor", "", "aobvh: weight floor, w = floor + (1-floor) x value",
        &P::ao_weight_floor, 0, 1, kOcclusion);
    add("ao_both_sides", "--ao-both-sides", "", "aobvh: cast AO rays from both triangle sides",
        &P::ao_both_sides, 0, 1, kOcclusion)
        .switch_flag = true;
    add("ao_normalise", "--ao-normalise", "",
        "aobvh: on = weights scaled to mean 1 (equal values give the SAH tree); off = the\n"
        "patent's literal sum of occlusion values in place of the count, same T2",
        &P::ao_normalise, 0, 1, kOcclusion);
    add("rdh_resolution", "--rdh-resolution", "rays per side",
        "rdh: sample primary rays per side per camera (0 = none: the SAH tree)", &P::rdh_resolution, 0,
        4096, kRayDistribution);
    add("rdh_ao_rays", "--rdh-ao-rays", "rays", "rdh: sample AO rays per primary hit", &P::rdh_ao_rays, 0,
        256, kRayDistribution);
    add("rdh_prior", "--rdh-prior", "rays",
        "rdh: k pseudo-rays spread by surface area, P_i = (A_i/A + n_i/k) / (1 + n/k)", &P::rdh_prior, 0,
        kInf, kRayDistribution)
        .min_exclusive = true;
    add("rdh_cameras", "--rdh-cameras", "",
        "rdh: camera = the run's camera only, all = every camera of the scene, none = no camera:\n"
        "AO rays from points spread by area over every triangle, either side (view-independent)",
        &P::rdh_cameras, 0, 0, kRayDistribution)
        .choices = {"camera", "all", "none"};
    return t;
  }();
  return kParameters;
}

const BuilderParameter* find_builder_parameter(const std::string& key) {
  for (const BuilderParameter& p : builder_parameters())
    if (p.key == key) return &p;
  return nullptr;
}

bool parameter_used_by(const BuilderParameter& parameter, const std::string& builder) {
  if (parameter.used_by.empty()) return true;
  for (const std::string& b : parameter.used_by)
    if (b == builder) return true;
  return false;
}

bool tree_depends_on_camera(const BuildParams& params) {
  if (!builder_info(params.builder).needs_camera) return false;
  return !parameter_used_by(*find_builder_parameter("rdh_cameras"), params.builder) ||
         params.rdh_cameras == "camera";
}

namespace {
std::string known_keys() {
  std::string keys;
  for (const BuilderParameter& p : builder_parameters())
    if (p.key != "width" && p.key != "threads") keys += (keys.empty() ? "" : ", ") + p.key;
  return keys;
}

std::string number_text(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}
}  // namespace

void set_build_parameter(BuildParams& target, const std::string& key, const std::string& text,
                         const std::string& where) {
  BuildParams params = target;  // target changes only when the value is accepted
  const BuilderParameter* p = find_builder_parameter(key);
  if (!p) throw InputError(where + key, "unknown builder parameter (known: " + known_keys() + ")");
  const std::string name = where + key;
  std::visit(
      [&](auto member) {
        using T = std::decay_t<decltype(params.*member)>;
        if constexpr (std::is_same_v<T, std::string>) {
          params.*member = text;
        } else if constexpr (std::is_same_v<T, bool>) {
          if (text == "on" || text == "true" || text == "1")
            params.*member = true;
          else if (text == "off" || text == "false" || text == "0")
            params.*member = false;
          else
            throw InputError(name, "'" + text + "' is not on/off (or true/false)");
        } else {
          // The strict reader (rtsim/workloads/numbers.h): "010", "0x10", "+2" and
          // "" are refused, and a seed past 2^53 keeps every digit.
          if constexpr (std::is_integral_v<T>) {
            params.*member = T(read_unsigned(text, 0, std::numeric_limits<T>::max(), name));
          } else {
            params.*member = T(read_real(text, -std::numeric_limits<double>::max(),
                                         std::numeric_limits<double>::max(), name));
          }
        }
      },
      p->field);
  // The range, as check_build_params checks it, named by this spelling.
  try {
    check_build_params(params);
  } catch (const InputError& e) {
    const std::string what = e.what();
    if (what.rfind(key + ": ", 0) == 0) throw InputError(name, what.substr(key.size() + 2));
    throw;
  }
  target = std::move(params);
}

void apply_build_setting(BuildParams& params, const std::string& assignment, const std::string& where) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(where, "'" + assignment + "' is not KEY=VALUE (keys: " + known_keys() + ")");
  set_build_parameter(params, assignment.substr(0, eq), assignment.substr(eq + 1), where + " ");
}

std::string build_parameter_text(const BuildParams& params, const BuilderParameter& parameter) {
  return std::visit(
      [&](auto member) -> std::string {
        using T = std::decay_t<decltype(params.*member)>;
        if constexpr (std::is_same_v<T, std::string>)
          return params.*member;
        else if constexpr (std::is_same_v<T, bool>)
          return params.*member ? "on" : "off";
        else if constexpr (std::is_integral_v<T>)
          return std::to_string(params.*member);
        else
          return number_text(params.*member);
      },
      parameter.field);
}

// ---- checks, over the table

void check_build_params(const BuildParams& params) {
  for (const BuilderParameter& p : builder_parameters()) {
    if (!p.choices.empty()) {
      const std::string& v = params.*std::get<std::string BuildParams::*>(p.field);
      if (std::find(p.choices.begin(), p.choices.end(), v) == p.choices.end()) {
        std::string list;
        for (const std::string& c : p.choices) list += (list.empty() ? "'" : ", '") + c + "'";
        throw InputError(p.key, "must be one of " + list + " (got '" + v + "')");
      }
      continue;
    }
    if (p.min == 0 && p.max == 0) continue;  // a name, not a number
    const double v = std::visit(
        [&](auto member) -> double {
          using T = std::decay_t<decltype(params.*member)>;
          if constexpr (std::is_same_v<T, std::string>) return 0;
          else return double(params.*member);
        },
        p.field);
    bool ok = std::isfinite(v) && v <= p.max && (p.min_exclusive ? v > p.min : v >= p.min);
    if (p.key == "bins" && v == 1) ok = false;
    if (ok) continue;
    std::string reason;
    if (p.key == "bins")
      reason = "must be 0 (full sweep) or 2..256";
    else if (p.key == "width")
      reason = "must be 2.." + std::to_string(kMaxBvhWidth) + " children per node";
    else if (p.min_exclusive && p.min == 0 && std::isinf(p.max))
      reason = "must be a positive finite number";
    else if (std::isinf(p.min) && std::isinf(p.max))
      reason = "must be finite";
    else if (std::isinf(p.max))
      reason = "must be >= " + number_text(p.min);
    else
      reason = "must be in [" + number_text(p.min) + ", " + number_text(p.max) + "]";
    throw InputError(p.key, reason);
  }
}

}  // namespace rtsim
