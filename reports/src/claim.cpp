// rtsim claim: the conditions map of the patent's relations (claim.h).
#include <rtsim/reports/claim.h>

#include "claim_internal.h"

#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/reports/campaign.h>
#include <rtsim/reports/campaign_runner.h>
#include <rtsim/reports/results_store.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/fetch.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/procedural.h>
#include <rtsim/workloads/scene_registry.h>
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/stat_names.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <set>
#include <sstream>

namespace rtsim {

namespace fs = std::filesystem;
using json = nlohmann::json;

using namespace claim_detail;

namespace claim_detail {

std::string picture_name(std::string relation) {
  const size_t lt = relation.find('<');
  if (lt != std::string::npos) relation.replace(lt, 1, "-lt-");
  return "claim_" + relation + ".png";
}

std::vector<std::string> claim_scenes(const ClaimOptions& o) {
  if (!o.scenes.empty()) return o.scenes;
  std::vector<std::string> out = procedural_scene_names();
  for (const RealSceneInfo& s : real_scene_catalogue())
    if (fs::exists(scene_cache_dir() / s.name / "scene.toml")) out.push_back(s.name);
  return out;
}

namespace {
bool samples_rays(const std::string& builder) {
  return parameter_used_by(*find_builder_parameter("rdh_resolution"), builder);
}
// With the builder's defaults, as the claim builds it (RDH from the traced camera).
bool depends_on_camera(const std::string& builder) {
  BuildParams params;
  params.builder = builder;
  return tree_depends_on_camera(params);
}
}  // namespace

// The camera-dependent builders (OSAH, RDH) for "unseen", the ray-sampling ones (RDH)
// for "surfaces", in the order run.
std::vector<std::string> condition_builders(const ClaimOptions& o, const std::string& trees) {
  std::vector<std::string> out;
  for (const auto* list : {&o.builders, &o.extra_builders})
    for (const std::string& b : *list)
      if (trees == "unseen" ? depends_on_camera(b) : samples_rays(b)) out.push_back(b);
  return out;
}

std::string interval_text(const Interval& i) {
  char b[64];
  if (!std::isfinite(i.lo)) {
    if (!std::isfinite(i.mean)) return "-";
    std::snprintf(b, sizeof b, "%+.1f%%", i.mean);
    return b;
  }
  std::snprintf(b, sizeof b, "%+.1f%% [%+.1f, %+.1f]", i.mean, i.lo, i.hi);
  return b;
}

}  // namespace claim_detail

namespace {

std::vector<Relation> relations(const ClaimOptions& o) {
  std::vector<Relation> r = {{"aobvh<sah", "aobvh", "sah", "AO-BVH (object) < SAH BVH"},
                             {"aobvh<sbvh", "aobvh", "sbvh", "AO-BVH (object) < SBVH"},
                             {"aobvh<osah", "aobvh", "osah", "AO-BVH (object) < OSAH"},
                             {"all<median", "", "median", "SAH, SBVH, OSAH, AO-BVH < median BVH"}};
  const std::set<std::string> extra(o.extra_builders.begin(), o.extra_builders.end());
  // The patent's AO-BVH read as splitting space (aosbvh): its relations where it is
  // built (the default condition, with the other extra trees).
  if (extra.count("aosbvh"))
    for (const char* other : {"sah", "sbvh", "osah"})
      r.push_back({std::string("aosbvh<") + other, "aosbvh", other,
                   "AO-BVH (spatial) < " + std::string(std::string(other) == "sah" ? "SAH BVH" : builder_info(other).display_name)});
  for (const std::string& ours : {std::string("rdh"), std::string("rdh-sbvh")}) {
    if (!extra.count(ours)) continue;
    for (const std::string& other : {std::string("sah"), std::string("sbvh"), std::string("aobvh"),
                                     std::string("aosbvh")})
      if (other != "aosbvh" || extra.count("aosbvh"))
        r.push_back({ours + "<" + other, ours, other,
                     builder_info(ours).display_name + " (ours) < " + builder_info(other).display_name});
  }
  return r;
}


// A condition: the level of every factor (the centre for all but at most one), and
// which rays the camera-dependent and ray-sampling trees were built from ("": the
// camera traced). Two conditions are the default for every tree but those:
// "unseen", OSAH and RDH built for another camera than the one traced (overfitting
// to the camera sampled is their known risk), and "surfaces", RDH from AO rays
// spread over the whole surface (rdh_cameras = none, view-independent).
using Condition = std::map<std::string, std::string>;
const char* const kTrees = "trees";

std::string condition_name(const Condition& c, const ClaimOptions& o) {
  for (const TreeOnlyCondition& t : kTreeOnlyConditions)
    if (c.at(kTrees) == t.level) return t.name;
  for (const ClaimFactor& f : o.factors)
    if (c.at(f.name) != f.centre) return f.name + "=" + c.at(f.name);
  return "default";
}


std::vector<Condition> star_conditions(const ClaimOptions& o) {
  Condition centre;
  for (const ClaimFactor& f : o.factors) centre[f.name] = f.centre;
  centre[kTrees] = "";
  std::vector<Condition> out = {centre};
  for (const TreeOnlyCondition& t : kTreeOnlyConditions) {
    if (condition_builders(o, t.level).empty() || (t.name == kUnseenName && o.cameras.size() < 2)) continue;
    out.push_back(centre);
    out.back()[kTrees] = t.level;
  }
  for (const ClaimFactor& f : o.factors)
    for (const std::string& level : f.levels)
      if (level != f.centre) {
        Condition c = centre;
        c[f.name] = level;
        out.push_back(c);
      }
  return out;
}

json number_text(const std::string& text) { return json::parse(text); }


// The condition a job runs under, read back from its resolved description.
Condition job_condition(const CampaignJob& job, const ClaimOptions& o) {
  auto setting = [&](const char* key) {
    auto it = job.build_settings.find(key);
    return it == job.build_settings.end() ? std::string() : it->second;
  };
  // A builder parameter at the builder's default is not in the job (the campaign
  // drops it: the same tree, the plain run); its level is the one that sets the default.
  auto level_of = [&](const ClaimFactor& f, const char* key) {
    const std::string set = setting(key);
    if (!set.empty()) return set;
    BuildParams plain;
    plain.builder = job.builder;
    for (const std::string& level : f.levels) {
      BuildParams at = plain;
      set_build_parameter(at, key, level);
      if (build_params_json(at) == build_params_json(plain)) return level;
    }
    return std::string();
  };
  Condition c;
  for (const ClaimFactor& f : o.factors) {
    if (f.name == "leaf") c[f.name] = level_of(f, "max_leaf_size");
    else if (f.name == "t2") c[f.name] = level_of(f, "t2");
    else if (f.name == "format") c[f.name] = job.node_format;
    else if (f.name == "cutoff") c[f.name] = job.ao_cutoff;
    else if (f.name == "diffuse") c[f.name] = std::to_string(std::max<int64_t>(0, job.diffuse_bounces));
    else if (f.name == "alpha") c[f.name] = job.opaque ? "off" : "on";
    else if (f.name == "instanced") c[f.name] = job.instanced ? "on" : "off";
  }
  c[kTrees] = setting("rdh_cameras") == "none" ? "surfaces" : job.tree_camera() != job.camera ? "unseen" : "";
  return c;
}


Figures figures_of(const json& stats) {
  Figures f;
  const auto s = flatten_stats(stats);
  auto get = [&](const std::string& k) {
    auto it = s.find(k);
    return it == s.end() ? NAN : it->second;
  };
  for (size_t m = 0; m < kMixCount; ++m) {
    const std::string mix = kMixes[m];
    if (mix == "all") {
      const double rays = get("rays.total");
      f.v[0][m] = (get("ops.trv") + get("ops.ist")) / rays;
      f.v[1][m] = get("fetches.node") / rays;
      f.v[2][m] = get("dram.bytes") / rays;
    } else {
      // The mix's ray types: one, or every diffuse depth the run traced.
      std::vector<std::string> types;
      for (RayType t : kAllRayTypes)
        if (mix == ray_type_name(t) || (mix == "diffuse" && diffuse_depth(t) > 0)) types.push_back(ray_type_name(t));
      double rays = 0, ops = 0, fetches = 0, bytes = 0;
      for (const std::string& type : types) {
        const std::string p = "per_type." + type + ".";
        const double n = get(p + "rays");
        if (!(n > 0)) continue;
        rays += n, ops += get(p + "trv_ops") + get(p + "ist_ops"), fetches += get(p + "node_fetches");
        // Every kind the ray type read (nodes, prim refs, triangles, stack).
        const std::string prefix = std::string(sim::stat::kDramBytesByType) + "." + type + ".";
        for (auto it = s.lower_bound(prefix); it != s.end() && it->first.compare(0, prefix.size(), prefix) == 0; ++it)
          if (std::isfinite(it->second)) bytes += it->second;
      }
      f.v[0][m] = rays > 0 ? ops / rays : NAN;
      f.v[1][m] = rays > 0 ? fetches / rays : NAN;
      f.v[2][m] = rays > 0 ? bytes / rays : NAN;
    }
  }
  return f;
}


std::string verdict(const Interval& i) {
  if (i.n < 2 || !std::isfinite(i.lo)) return "n/a";
  if (i.hi < 0) return "holds";
  if (i.lo > 0) return "reverses";
  return "noise";
}


}  // namespace

double spearman(const std::vector<double>& x, const std::vector<double>& y) {
  const size_t n = std::min(x.size(), y.size());
  if (n < 3) return NAN;
  auto ranks = [n](const std::vector<double>& v) {
    std::vector<size_t> order(n);
    std::iota(order.begin(), order.end(), size_t(0));
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return v[a] < v[b]; });
    std::vector<double> r(n);
    for (size_t i = 0; i < n;) {
      size_t j = i;
      while (j + 1 < n && v[order[j + 1]] == v[order[i]]) ++j;
      for (size_t k = i; k <= j; ++k) r[order[k]] = 0.5 * double(i + j) + 1;  // ties share the mean rank
      i = j + 1;
    }
    return r;
  };
  const std::vector<double> rx = ranks(x), ry = ranks(y);
  const double mx = std::accumulate(rx.begin(), rx.end(), 0.0) / double(n);
  const double my = std::accumulate(ry.begin(), ry.end(), 0.0) / double(n);
  double sxy = 0, sxx = 0, syy = 0;
  for (size_t i = 0; i < n; ++i) {
    sxy += (rx[i] - mx) * (ry[i] - my);
    sxx += (rx[i] - mx) * (rx[i] - mx);
    syy += (ry[i] - my) * (ry[i] - my);
  }
  if (sxx == 0 || syy == 0) return NAN;
  return sxy / std::sqrt(sxx * syy);
}

ClaimOptions quick_claim_options(ClaimOptions o) {
  o.quick = true;
  if (o.scenes.empty()) o.scenes = {"cornell"};
  o.extra_builders = {"rdh"};
  o.factors = {{"leaf", {"4", "8"}, "4"},
               {"format", {"bvh2-64", "bvh4-128"}, "bvh2-64"},
               {"cutoff", {"0.05", "0.2"}, "0.05"},
               {"diffuse", {"0", "1"}, "0"}};
  o.replicates = 3;
  o.resolution = "32x32";
  return o;
}

std::string claim_campaign_json(const ClaimOptions& o) {
  if (o.replicates < 2) throw InputError("--replicates", "needs at least 2 for an interval");
  for (const ClaimFactor& f : o.factors)
    if (std::find(f.levels.begin(), f.levels.end(), f.centre) == f.levels.end())
      throw InputError("claim factor '" + f.name + "'", "its default " + f.centre + " is not one of its levels");
  json doc;
  doc["campaign"] = {{"name", "claim"},
                     {"description", "rtsim claim: the patent's relations over a star design of conditions"}};
  json seeds = json::array();
  for (uint32_t r = 1; r <= o.replicates; ++r) seeds.push_back(r);
  doc["sweep"] = {{"scene", claim_scenes(o)},
                  {"camera", o.cameras},
                  {"preset", o.preset},
                  {"fidelity", "functional"},
                  {"resolution", o.resolution},
                  {"ao", o.ao_rays},
                  {"frames", o.frames},
                  {"seed", seeds}};
  json groups = json::array();
  const std::vector<Condition> conditions = star_conditions(o);
  // The scenes alpha testing changes (loaded once each, from the scene cache): the
  // others would run the alpha=off condition as the default's workload again.
  std::vector<std::string> alpha_scenes;
  for (const ClaimFactor& f : o.factors)
    if (f.name == "alpha")
      for (const std::string& scene : claim_scenes(o))
        if (load_scene(scene).alpha_tested_triangles() > 0) alpha_scenes.push_back(scene);
  // Likewise the scenes that have instances, for the instanced=on level.
  std::vector<std::string> instanced_scenes;
  for (const ClaimFactor& f : o.factors)
    if (f.name == "instanced")
      for (const std::string& scene : claim_scenes(o))
        if (load_scene(scene, SceneForm::Instanced).instanced()) instanced_scenes.push_back(scene);
  // One group per condition (and per traced camera where the trees are built for
  // another); a second one for the ray-distribution builders' own sampling setting.
  struct Part {
    Condition condition;
    std::string name, camera, tree_camera;
    std::vector<std::string> builders;
  };
  std::vector<Part> parts;
  for (size_t i = 0; i < conditions.size(); ++i) {
    const Condition& c = conditions[i];
    if (c.at(kTrees) == "unseen") {
      // Camera k's rays through the trees built for camera k+1: each tree is traced
      // from the camera it did not sample; the other trees are the default's.
      for (size_t k = 0; k < o.cameras.size(); ++k)
        parts.push_back({c, condition_name(c, o) + ":" + o.cameras[k], o.cameras[k],
                         o.cameras[(k + 1) % o.cameras.size()], condition_builders(o, "unseen")});
      continue;
    }
    if (c.at(kTrees) == "surfaces") {
      parts.push_back({c, condition_name(c, o), "", "", condition_builders(o, "surfaces")});
      continue;
    }
    Part p{c, condition_name(c, o), "", "", o.builders};
    if (i == 0) p.builders.insert(p.builders.end(), o.extra_builders.begin(), o.extra_builders.end());
    parts.push_back(p);
  }
  for (const Part& part : parts) {
    const Condition& c = part.condition;
    std::vector<std::string> builders, samplers;
    for (const std::string& b : part.builders) (samples_rays(b) ? samplers : builders).push_back(b);
    json g = {{"name", part.name}};
    if (!builders.empty()) g["builder"] = builders;
    if (!part.camera.empty()) g["camera"] = part.camera;
    if (c.count("format")) g["node_format"] = c.at("format");
    if (c.count("cutoff")) g["ao_cutoff"] = number_text(c.at("cutoff"));
    // No bounces is the sweep's own workload: the same jobs as before the axis existed.
    if (c.count("diffuse") && c.at("diffuse") != "0") g["diffuse_bounces"] = number_text(c.at("diffuse"));
    if (c.count("alpha") && c.at("alpha") == "off") {
      if (alpha_scenes.empty()) continue;  // no scene has alpha-tested materials
      g["opaque"] = true;
      g["scene"] = alpha_scenes;
    }
    if (c.count("instanced") && c.at("instanced") == "on") {
      if (instanced_scenes.empty()) continue;  // no scene has instances
      g["instanced"] = true;
      g["scene"] = instanced_scenes;
    }
    json build = json::object();
    if (c.count("leaf")) build["max_leaf_size"] = number_text(c.at("leaf"));
    if (c.count("t2")) build["t2"] = number_text(c.at("t2"));
    if (!part.tree_camera.empty()) build["camera"] = part.tree_camera;
    if (!build.empty()) g["build"] = build;
    if (!builders.empty()) groups.push_back(g);
    // The ray-distribution builders sample primary rays through pixel centres: on a
    // grid of 3/4 the workload's, so that the rays measured are not the rays sampled.
    if (!samplers.empty()) {
      uint32_t w = 0, h = 0;
      std::sscanf(o.resolution.c_str(), "%ux%u", &w, &h);
      json ours = g;
      ours["name"] = part.name + "-sampling";
      ours["builder"] = samplers;
      ours["build"]["rdh_resolution"] = std::max<uint32_t>(8, w * 3 / 4);
      if (c.at(kTrees) == "surfaces") {  // no camera grid: points over the surface
        ours["name"] = part.name;
        ours["build"]["rdh_cameras"] = "none";
        ours["build"]["rdh_resolution"] = kSurfaceResolution;
      }
      groups.push_back(ours);
    }
  }
  doc["group"] = groups;
  return doc.dump(2) + "\n";
}

namespace {

// A tree's costs (from the tree cache's reports) and its measured figures, for the
// correlations.
struct TreePoint {
  std::string builder, condition;
  double sah = NAN, weighted = NAN, epo = NAN;
  Figures measured;
};
using TreePoints = std::map<std::tuple<std::string, std::string, std::string>, std::vector<TreePoint>>;

// The figures of every ok job, by (scene, camera, condition) -> builder -> replicate.
struct ClaimFigures {
  FiguresByWhere figures;
  TreePoints tree_points;      // by (scene, camera, seed)
  BuildSeconds build_seconds;  // the default condition's trees and the tree-only ones
  size_t failed = 0;           // jobs without an ok result
};

ClaimFigures collect_figures(const ClaimOptions& o, const Campaign& campaign, const CampaignPaths& paths,
                             const std::map<Condition, std::string>& names) {
  ResultsStore store(paths.database, ResultsStore::Access::ReadOnly);
  std::map<std::string, json> stats_by_key;
  for (const json& row : store.rows(campaign.name)) {
    if (row.value("status", "") != "ok") continue;
    if (!row.contains("stats_json") || !row["stats_json"].is_string()) continue;
    stats_by_key[row["job_key"].get<std::string>()] = json::parse(row["stats_json"].get<std::string>());
  }
  ClaimFigures out;
  for (const CampaignJob& job : campaign.jobs) {
    auto it = stats_by_key.find(job.key);
    if (it == stats_by_key.end()) {
      ++out.failed;
      continue;
    }
    auto name = names.find(job_condition(job, o));
    if (name == names.end()) continue;
    const Figures f = figures_of(it->second);
    out.figures[{job.scene, job.camera, name->second}][job.builder][job.seed] = f;
    if (o.tree_cache.empty()) continue;
    const fs::path report = fs::path(cached_tree(o.tree_cache, campaign, job).string() + ".metrics.json");
    if (!fs::exists(report)) continue;
    const json m = json::parse(read_input_file(report, kMaxConfigFileBytes), nullptr, false);
    if (!m.is_object()) continue;
    TreePoint p;
    p.builder = job.builder;
    p.condition = name->second;
    p.sah = m.value("sah_cost", NAN);
    p.weighted = m.value("weighted_cost", NAN);
    p.epo = m.value("epo", NAN);
    if (name->second == "default" || name->second == kSurfacesName)
      out.build_seconds[{job.scene, job.builder, name->second}].push_back(m.value("build_seconds", NAN));
    p.measured = f;
    // The costs are in units of T1 and T2: one cost scale only where T2/T1 = 1, and
    // one workload only at the default AO length.
    const Condition c = job_condition(job, o);
    bool comparable = true;
    for (const ClaimFactor& fac : o.factors)
      if ((fac.name == "t2" || fac.name == "cutoff" || fac.name == "diffuse" || fac.name == "alpha" ||
           fac.name == "instanced") &&
          c.at(fac.name) != fac.centre)
        comparable = false;
    if (c.at(kTrees) != "") comparable = false;  // the default's trees, or costs for rays not traced
    if (comparable) out.tree_points[{job.scene, job.camera, std::to_string(job.seed)}].push_back(p);
  }
  return out;
}

// The tree-only conditions have only the trees they rebuild; the others are the
// default condition's (the same trees and rays), copied in here. Returns each
// tree-only condition's rebuilt builders.
std::map<std::string, std::set<std::string>> borrow_default_trees(const ClaimOptions& o, FiguresByWhere& figures) {
  std::map<std::string, std::set<std::string>> rebuilt;  // tree-only condition name -> builders
  for (const TreeOnlyCondition& t : kTreeOnlyConditions)
    for (const std::string& b : condition_builders(o, t.level)) rebuilt[t.name].insert(b);
  for (auto& [where, by_builder] : figures) {
    if (!rebuilt.count(std::get<2>(where))) continue;
    auto centre = figures.find({std::get<0>(where), std::get<1>(where), "default"});
    if (centre == figures.end()) continue;
    for (const auto& [builder, runs] : centre->second) by_builder.emplace(builder, runs);
  }
  return rebuilt;
}

// One relation's cell: the paired per-replicate differences of tree a against b
// (every a for all<median), and the verdict.
Cell relation_cell(const Relation& rel, const std::vector<std::string>& as,
                   const std::map<std::string, std::map<uint64_t, Figures>>& by_builder, const std::string& scene,
                   const std::string& camera, const std::string& condition, size_t m, size_t x) {
  Cell cell{rel.name, scene, camera, condition, kMetrics[m], kMixes[x], {}, ""};
  std::vector<Interval> per_a;
  for (const std::string& a : as) {
    std::vector<double> d;
    for (const auto& [seed, fb] : by_builder.at(rel.b)) {
      auto fa = by_builder.at(a).find(seed);
      if (fa == by_builder.at(a).end()) continue;
      const double vb = fb.v[m][x], va = fa->second.v[m][x];
      if (std::isfinite(va) && std::isfinite(vb) && vb > 0) d.push_back(100.0 * (va / vb - 1));
    }
    per_a.push_back(interval_of(d));
  }
  // all<median: holds if every tree holds; reverses if any reverses; the
  // effect shown is the least favourable tree's.
  size_t worst = 0;
  for (size_t k = 1; k < per_a.size(); ++k)
    if (per_a[k].mean > per_a[worst].mean) worst = k;
  cell.effect = per_a[worst];
  bool all_hold = true, any_reverse = false, any_na = false;
  for (const Interval& i : per_a) {
    const std::string v = verdict(i);
    all_hold = all_hold && v == "holds";
    any_reverse = any_reverse || v == "reverses";
    any_na = any_na || v == "n/a";
  }
  cell.verdict = any_na ? "n/a" : all_hold ? "holds" : any_reverse ? "reverses" : "noise";
  // DRAM bytes of a scene that fits the caches are ~0: no relation to read.
  if (std::string(kMetrics[m]) == "dram_bytes") {
    double b = 0;
    for (const auto& [seed, fb] : by_builder.at(rel.b)) b = std::max(b, fb.v[m][x]);
    if (!(b > 0.5)) cell.verdict = "n/a";
  }
  return cell;
}

// Every relation's cells where both its trees ran. In a tree-only condition a
// relation of trees it did not rebuild is the default's cell again: counting it
// twice would inflate the tallies.
std::vector<Cell> claim_cells(const FiguresByWhere& figures, const std::vector<Relation>& rels,
                              const std::map<std::string, std::set<std::string>>& rebuilt) {
  std::vector<Cell> cells;
  for (const auto& [where, by_builder] : figures) {
    const auto& [scene, camera, condition] = where;
    for (const Relation& rel : rels) {
      std::vector<std::string> as;
      if (rel.a.empty()) as = {"sah", "sbvh", "osah", "aobvh"};
      else as = {rel.a};
      bool present = by_builder.count(rel.b);
      for (const std::string& a : as) present = present && by_builder.count(a);
      if (!present) continue;
      if (rebuilt.count(condition)) {
        const std::set<std::string>& trees = rebuilt.at(condition);
        bool involved = trees.count(rel.b) > 0;
        for (const std::string& a : as) involved = involved || trees.count(a) > 0;
        if (!involved) continue;
      }
      for (size_t x = 0; x < kMixCount; ++x) {
        // A mix the condition does not trace (diffuse rays without bounces) has no cells.
        bool traced = false;
        for (const auto& [seed, f] : by_builder.at(rel.b)) traced = traced || std::isfinite(f.v[0][x]);
        if (!traced) continue;
        for (size_t m = 0; m < kMetricCount; ++m)
          cells.push_back(relation_cell(rel, as, by_builder, scene, camera, condition, m, x));
      }
    }
  }
  return cells;
}

// Per scene, camera and mix, over replicate-averaged points, for two sets of trees:
// every tree of the map (leaf sizes and formats spread the costs wide), and the
// default condition's trees without the median BVH (does the cost rank the good
// trees?).
std::vector<Correlation> claim_correlations(const TreePoints& tree_points) {
  std::vector<Correlation> correlations;
  std::map<std::pair<std::string, std::string>, std::map<std::pair<std::string, std::string>, std::vector<const TreePoint*>>> grouped;
  for (const auto& [k, pts] : tree_points)
    for (const TreePoint& p : pts) grouped[{std::get<0>(k), std::get<1>(k)}][{p.builder, p.condition}].push_back(&p);
  for (const bool all_trees : {true, false})
    for (const auto& [sc, trees] : grouped)
      for (size_t x = 0; x < kMixCount; ++x) {
        std::vector<double> sah, weighted, epo, ops;
        for (const auto& [tree, pts] : trees) {
          if (!all_trees && (tree.first == "median" || tree.second != "default")) continue;
          double s = 0, w = 0, e = 0, v = 0;
          for (const TreePoint* p : pts) s += p->sah, w += p->weighted, e += p->epo, v += p->measured.v[0][x];
          const double n = double(pts.size());
          if (!std::isfinite(v)) continue;
          sah.push_back(s / n), weighted.push_back(w / n), epo.push_back(e / n), ops.push_back(v / n);
        }
        if (ops.empty()) continue;  // a mix the comparable trees' runs do not trace
        Correlation c{sc.first, sc.second, kMixes[x], all_trees ? "all" : "default, no median", ops.size(),
                      spearman(sah, ops), spearman(weighted, ops), NAN};
        bool have_epo = std::all_of(epo.begin(), epo.end(), [](double d) { return std::isfinite(d); });
        if (have_epo) c.epo = spearman(epo, ops);
        correlations.push_back(c);
      }
  return correlations;
}

// Per relation, metric and mix: where it holds and where it reverses, in words.
// Adds the cells that hold and reverse to *holds and *reverses.
std::vector<std::string> claim_sentences(const std::vector<Relation>& rels, const std::vector<Cell>& cells,
                                         size_t* holds_total, size_t* reverses_total) {
  std::vector<std::string> sentences;
  for (const Relation& rel : rels) {
    for (size_t m = 0; m < kMetricCount; ++m)
      for (size_t x = 0; x < kMixCount; ++x) {
        size_t holds = 0, reverses = 0, noise = 0;
        // Per condition and per scene/camera: cells that hold, that reverse, and all cells.
        std::map<std::string, std::array<size_t, 3>> by_condition, by_view;
        for (const Cell& c : cells) {
          if (c.relation != rel.name || c.metric != kMetrics[m] || c.mix != kMixes[x] || c.verdict == "n/a") continue;
          auto& t = by_condition[c.condition];
          auto& u = by_view[c.scene + "/" + c.camera];
          if (c.verdict == "holds") ++holds, ++t[0], ++u[0];
          else if (c.verdict == "reverses") ++reverses, ++t[1], ++u[1];
          else ++noise;
          ++t[2], ++u[2];
        }
        const size_t total = holds + reverses + noise;
        if (total == 0) continue;
        std::ostringstream s;
        s << rel.text << ", " << kMetricText[m] << ", " << kMixes[x] << " rays: holds in " << holds << " of "
          << total << " cells (scene x camera x condition), reverses in " << reverses << ", noise in " << noise
          << ".";
        std::string held, reversed;
        for (const auto& [cond, t] : by_condition) {
          const std::string of = " " + std::to_string(t[0]) + "/" + std::to_string(t[2]);
          if (t[0] > 0) held += (held.empty() ? "" : ", ") + cond + of;
          if (t[1] > 0)
            reversed += (reversed.empty() ? "" : ", ") + cond + " " + std::to_string(t[1]) + "/" + std::to_string(t[2]);
        }
        if (!held.empty()) s << " Holds at " << held << ".";
        if (!reversed.empty()) s << " Reverses at " << reversed << ".";
        // Scenes and cameras where it holds (or reverses) in every condition of the map.
        std::string always, never;
        for (const auto& [view, u] : by_view) {
          if (u[0] == u[2]) always += (always.empty() ? "" : ", ") + view;
          if (u[1] == u[2]) never += (never.empty() ? "" : ", ") + view;
        }
        if (!always.empty()) s << " Holds in every condition on " << always << ".";
        if (!never.empty()) s << " Reverses in every condition on " << never << ".";
        sentences.push_back(s.str());
        *holds_total += holds;
        *reverses_total += reverses;
      }
  }
  return sentences;
}

}  // namespace

ClaimSummary run_claim(const ClaimOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  const std::string document = claim_campaign_json(o);  // bad options stop here, before any file
  fs::create_directories(o.out_dir);
  const fs::path campaign_file = fs::absolute(o.out_dir) / "claim-campaign.json";
  write_file_atomic(campaign_file, document);
  const std::string revision = binary_revision(o.rtsim_binary);
  const Campaign campaign = load_campaign(campaign_file, revision);
  const CampaignPaths paths = campaign_paths(campaign, fs::absolute(o.out_dir) / "campaign", {});
  RunOptions run;
  run.parallel = o.jobs;
  run.binary = o.rtsim_binary;
  run.progress = o.progress;
  run.tree_cache = o.tree_cache;
  run.retry_failed = o.retry_failed;
  const RunSummary ran = run_campaign(campaign, paths, run);
  ClaimSummary summary;
  if (ran.interrupted) {
    summary.interrupted = true;
    return summary;
  }
  summary.jobs = campaign.jobs.size();
  summary.ran = ran.ran;

  const std::vector<Condition> conditions = star_conditions(o);
  std::map<Condition, std::string> names;
  for (const Condition& c : conditions) names[c] = condition_name(c, o);
  ClaimFigures collected = collect_figures(o, campaign, paths, names);
  summary.failed = collected.failed;
  const auto rebuilt = borrow_default_trees(o, collected.figures);
  const std::vector<Relation> rels = relations(o);
  std::vector<Cell> cells = claim_cells(collected.figures, rels, rebuilt);
  summary.cells = cells.size();
  std::vector<Correlation> correlations = claim_correlations(collected.tree_points);
  const std::vector<std::string> sentences = claim_sentences(rels, cells, &summary.holds, &summary.reverses);

  // The report, and the summary printed
  ClaimAnalysis analysis{rels, {}, std::move(collected.figures), std::move(collected.build_seconds), std::move(cells),
                         std::move(correlations), sentences};
  for (const Condition& c : conditions) analysis.conditions.push_back(names[c]);
  const std::string plot_note =
      write_claim_report(o, analysis, ClaimRun{summary.jobs, ran.ran, summary.failed, ran.wall_seconds, revision});
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::ostringstream text;
  text << "claim: " << summary.jobs << " jobs (" << ran.ran << " run now, " << summary.failed
       << " missing or failed), " << summary.cells << " cells: " << summary.holds << " hold, "
       << summary.reverses << " reverse\n";
  for (const std::string& s : sentences)
    if (s.find(", all rays:") != std::string::npos && s.find("TRV+IST") != std::string::npos) text << "  " << s << "\n";
  text << plot_note;
  summary.text = text.str();
  return summary;
}

}  // namespace rtsim
