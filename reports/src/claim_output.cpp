// rtsim claim's report: claim.{json,csv,md} and the heatmaps (claim_internal.h).
#include "claim_internal.h"

#include <rtsim/builder/builder_registry.h>
#include <rtsim/reports/plot_script.h>
#include <rtsim/reports/text_table.h>
#include <rtsim/workloads/files.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <sstream>

namespace rtsim::claim_detail {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

json finite_or_null(double d) { return std::isfinite(d) ? json(d) : json(nullptr); }

json options_json(const ClaimOptions& o) {
  json options = {{"scenes", claim_scenes(o)},  {"cameras", o.cameras},
                  {"builders", o.builders},     {"extra_builders", o.extra_builders},
                  {"replicates", o.replicates}, {"resolution", o.resolution},
                  {"ao_rays", o.ao_rays},       {"frames", o.frames},
                  {"preset", o.preset},         {"quick", o.quick}};
  json factors = json::array();
  for (const ClaimFactor& f : o.factors) factors.push_back({{"name", f.name}, {"levels", f.levels}, {"default", f.centre}});
  options["factors"] = factors;
  return options;
}

// The cells as claim.json's list and as claim.csv's rows.
json cells_json(const std::vector<Cell>& cells, TextTable& csv) {
  auto cnum = [](double d) {
    if (!std::isfinite(d)) return std::string();
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", d);
    return std::string(b);
  };
  json jcells = json::array();
  for (const Cell& c : cells) {
    jcells.push_back({{"relation", c.relation}, {"scene", c.scene}, {"camera", c.camera},
                      {"condition", c.condition}, {"metric", c.metric}, {"mix", c.mix},
                      {"n", c.effect.n}, {"mean_pct", finite_or_null(c.effect.mean)},
                      {"ci_lo_pct", finite_or_null(c.effect.lo)}, {"ci_hi_pct", finite_or_null(c.effect.hi)},
                      {"verdict", c.verdict}});
    csv.add_row({c.relation, c.scene, c.camera, c.condition, c.metric, c.mix, std::to_string(c.effect.n),
                 cnum(c.effect.mean), cnum(c.effect.lo), cnum(c.effect.hi), c.verdict});
  }
  return jcells;
}

void write_intro(std::ostringstream& md, const ClaimOptions& o, const ClaimRun& run,
                 const std::vector<std::string>& sentences) {
  md << "# Where the patent's claim holds\n\n"
     << "Star design around the defaults (";
  for (size_t i = 0; i < o.factors.size(); ++i)
    md << (i ? ", " : "") << o.factors[i].name << " " << o.factors[i].centre;
  md << "), each factor varied alone; " << claim_scenes(o).size() << " scenes x " << o.cameras.size()
     << " cameras; " << o.replicates << " replicates (seed r: the workload's rays and the builder's "
     << "AO/sample rays); " << o.resolution << ", " << o.ao_rays << " AO rays per hit, frame " << o.frames
     << " of " << o.frames << " (warm caches), preset " << o.preset << ", functional level. "
     << run.jobs << " jobs.\n\n"
     << "Effect = mean over replicates of (a / b - 1) in %, with a 95% t interval. "
     << "**holds**: the interval is below 0; **reverses**: above 0; **noise**: it contains 0. "
     << "For `all<median` every tree must hold; the effect shown is the least favourable tree's. "
     << "AO-only and primary-only figures are those ray types' shares of one run (shared caches); "
     << "DRAM cells of a run under 0.5 B/ray are n/a.\n\n## In sentences\n\n";
  for (const std::string& s : sentences) md << "- " << s << "\n";
}

void write_tally(std::ostringstream& md, const std::vector<Relation>& rels, const std::vector<Cell>& cells) {
  md << "\n## Tally per relation (all metrics and mixes)\n\n";
  TextTable t({"relation", "holds", "reverses", "noise", "n/a"});
  for (const Relation& rel : rels) {
    size_t h = 0, r = 0, n = 0, na = 0;
    for (const Cell& c : cells)
      if (c.relation == rel.name)
        (c.verdict == "holds" ? h : c.verdict == "reverses" ? r : c.verdict == "noise" ? n : na)++;
    if (h + r + n + na)
      t.add_row({rel.text, std::to_string(h), std::to_string(r), std::to_string(n), std::to_string(na)});
  }
  md << t.markdown() << "\n";
}

// Per relation: scene/camera rows against the conditions, the ops/ray effect of all rays.
void write_ops_grids(std::ostringstream& md, const std::vector<Relation>& rels, const std::vector<Cell>& cells,
                     const std::vector<std::string>& conds) {
  md << "## Ops/ray, all rays, per condition\n\n";
  for (const Relation& rel : rels) {
    std::vector<std::string> header = {"scene/camera"};
    header.insert(header.end(), conds.begin(), conds.end());
    TextTable t(header);
    std::map<std::string, std::map<std::string, const Cell*>> grid;
    for (const Cell& c : cells)
      if (c.relation == rel.name && c.metric == std::string("ops") && c.mix == std::string("all"))
        grid[c.scene + "/" + c.camera][c.condition] = &c;
    if (grid.empty()) continue;
    for (const auto& [sc, row] : grid) {
      std::vector<std::string> r = {sc};
      for (const std::string& cond : conds) {
        auto it = row.find(cond);
        r.push_back(it == row.end() ? "" : interval_text(it->second->effect) +
                                               (it->second->verdict == "holds"      ? " holds"
                                                : it->second->verdict == "reverses" ? " REV"
                                                                                    : ""));
      }
      t.add_row(r);
    }
    md << "### " << rel.text << "\n\n" << t.markdown() << "\n";
    md << "![" << rel.name << "](" << picture_name(rel.name) << ")\n\n";
  }
}

// Every builder at the default condition, then the trees of the tree-only
// conditions: absolute figures with their intervals, in Markdown and as returned JSON.
json write_default_condition(std::ostringstream& md, const ClaimOptions& o, const FiguresByWhere& figures,
                             const BuildSeconds& build_seconds) {
  md << "## Every builder at the default condition\n\n"
     << "Mean over the replicates and the 95% half-width. Build s: wall seconds of one build "
     << "(2 threads, beside a running job; the cached tree's own report), mean over the trees of the "
     << "default condition. \"Built for another camera\": the tree of a camera-dependent builder "
     << "traced from a camera it did not sample (condition " << kUnseenName << "); \"from surface AO "
     << "rays\": RDH from " << kSurfaceResolution << "^2 points over the whole surface, no camera (condition "
     << kSurfacesName << ").\n\n";
  json defaults = json::array();
  TextTable t({"scene/camera", "builder", "ops/ray primary", "ops/ray AO", "node fetches/ray", "DRAM B/ray",
               "build s"});
  auto pm = [](const Interval& i) {
    if (!std::isfinite(i.mean)) return std::string("-");
    char b[48];
    if (std::isfinite(i.hi)) std::snprintf(b, sizeof b, "%.3g +- %.2g", i.mean, i.hi - i.mean);
    else std::snprintf(b, sizeof b, "%.3g", i.mean);
    return std::string(b);
  };
  struct Shown {
    std::string builder, condition, trees, suffix;
  };
  std::vector<Shown> order;
  for (const auto* list : {&o.builders, &o.extra_builders})
    for (const std::string& b : *list) order.push_back({b, "default", "default", ""});
  for (const TreeOnlyCondition& c : kTreeOnlyConditions)
    for (const std::string& b : condition_builders(o, c.level)) order.push_back({b, c.name, c.level, c.suffix});
  for (const auto& entry : figures) {
    const auto& where = entry.first;
    if (std::get<2>(where) != "default") continue;
    for (const Shown& row : order) {
      const std::string& b = row.builder;
      const auto other = figures.find({std::get<0>(where), std::get<1>(where), row.condition});
      if (other == figures.end()) continue;
      const auto& by_builder = other->second;
      auto it = by_builder.find(b);
      if (it == by_builder.end()) continue;
      auto series = [&](size_t m, size_t x) {
        std::vector<double> v;
        for (const auto& [seed, f] : it->second) v.push_back(f.v[m][x]);
        return interval_of(v);
      };
      const Interval prim = series(0, 0), ao = series(0, 1), fetch = series(1, 2), dram = series(2, 2);
      const auto bs = build_seconds.find({std::get<0>(where), b, row.condition});
      const double secs = bs == build_seconds.end() ? NAN : interval_of(bs->second).mean;
      char sb[32];
      std::snprintf(sb, sizeof sb, "%.3g", secs);
      const std::string shown = builder_info(b).display_name + (builder_info(b).ours ? " (ours)" : "") + row.suffix;
      t.add_row({std::get<0>(where) + "/" + std::get<1>(where), shown, pm(prim), pm(ao), pm(fetch), pm(dram),
                 std::isfinite(secs) ? std::string(sb) : "-"});
      defaults.push_back({{"scene", std::get<0>(where)}, {"camera", std::get<1>(where)}, {"builder", b},
                          {"trees", row.trees},
                          {"ops_per_ray_primary", finite_or_null(prim.mean)},
                          {"ops_per_ray_primary_half", finite_or_null(prim.hi - prim.mean)},
                          {"ops_per_ray_ao", finite_or_null(ao.mean)},
                          {"ops_per_ray_ao_half", finite_or_null(ao.hi - ao.mean)},
                          {"node_fetches_per_ray", finite_or_null(fetch.mean)},
                          {"dram_bytes_per_ray", finite_or_null(dram.mean)},
                          {"dram_bytes_per_ray_half", finite_or_null(dram.hi - dram.mean)},
                          {"build_seconds", finite_or_null(secs)}});
    }
  }
  md << t.markdown() << "\n";
  return defaults;
}

void write_correlations(std::ostringstream& md, const std::vector<Correlation>& correlations) {
  md << "## Does the cost model predict the work?\n\n"
     << "Spearman rank correlation between the tree's modelled cost and its measured TRV+IST ops/ray "
     << "(replicate means), over two sets of trees: **all**, every tree of the map at T2/T1 = 1 and "
     << "the default AO length (builders x leaf sizes x node formats: the costs spread wide), and "
     << "**default, no median**, the default condition's trees without the median BVH (does the cost "
     << "rank the good trees?). The weighted cost is in each builder's own units (AO-BVH's weight "
     << "sums), so across builders it is not one scale.\n\n";
  TextTable t({"trees", "scene", "camera", "rays", "n", "SAH cost", "weighted cost", "EPO"});
  auto r3 = [](double d) {
    if (!std::isfinite(d)) return std::string("-");
    char b[16];
    std::snprintf(b, sizeof b, "%.2f", d);
    return std::string(b);
  };
  for (const Correlation& c : correlations)
    t.add_row({c.trees, c.scene, c.camera, c.mix, std::to_string(c.points), r3(c.sah), r3(c.weighted), r3(c.epo)});
  md << (correlations.empty() ? std::string("(no tree reports: run with the tree cache)\n") : t.markdown()) << "\n";
}

}  // namespace

std::string write_claim_report(const ClaimOptions& o, const ClaimAnalysis& a, const ClaimRun& run) {
  json out;
  out["options"] = options_json(o);
  out["jobs"] = run.jobs;
  out["jobs_run_now"] = run.ran;
  out["jobs_missing_or_failed"] = run.failed;
  out["run_seconds"] = run.run_seconds;
  out["revision"] = run.revision;
  json jrels = json::array();
  for (const Relation& r : a.relations) jrels.push_back({{"name", r.name}, {"text", r.text}});
  out["relations"] = jrels;
  TextTable csv({"relation", "scene", "camera", "condition", "metric", "mix", "n", "mean_pct", "ci_lo_pct",
                 "ci_hi_pct", "verdict"});
  out["cells"] = cells_json(a.cells, csv);
  out["conditions"] = a.conditions;  // in design order: the default first
  json jcorr = json::array();
  for (const Correlation& c : a.correlations)
    jcorr.push_back({{"scene", c.scene}, {"camera", c.camera}, {"mix", c.mix}, {"trees", c.trees}, {"points", c.points},
                     {"sah_cost", finite_or_null(c.sah)}, {"weighted_cost", finite_or_null(c.weighted)},
                     {"epo", finite_or_null(c.epo)}});
  out["cost_model_correlations"] = jcorr;
  out["sentences"] = a.sentences;

  // Markdown: the tallies, the sentences, the builders at the default, correlations.
  std::ostringstream md;
  write_intro(md, o, run, a.sentences);
  write_tally(md, a.relations, a.cells);
  write_ops_grids(md, a.relations, a.cells, a.conditions);
  out["default_condition"] = write_default_condition(md, o, a.figures, a.build_seconds);
  write_correlations(md, a.correlations);

  write_file_atomic(o.out_dir / "claim.json", out.dump(2) + "\n");
  write_file_atomic(o.out_dir / "claim.csv", csv.csv());
  write_file_atomic(o.out_dir / "claim.md", md.str());
  std::string plot_note;
  try {
    run_plot_script("claim_plots.py", {fs::absolute(o.out_dir).string()});
  } catch (const std::exception& e) {
    plot_note = std::string("pictures not drawn: ") + e.what() + "\n";
  }
  return plot_note;
}

}  // namespace rtsim::claim_detail
