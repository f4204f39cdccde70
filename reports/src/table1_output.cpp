#include <rtsim/builder/builder_registry.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/reports/plot_script.h>
#include <rtsim/reports/table1.h>
#include <rtsim/reports/text_table.h>
#include <rtsim/workloads/files.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <tuple>

namespace rtsim {

namespace {

bool is_preset(const std::string& hardware) {
  for (const std::string& p : sim::preset_names())
    if (p == hardware) return true;
  return false;
}

std::string pct(double value, double baseline) {
  if (baseline <= 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f%%", 100.0 * (1.0 - value / baseline));
  return buf;
}

// Prose for the terminal, wrapped at word boundaries to fit 120 columns; lines
// after the first start with `indent`.
std::string wrap(const std::string& text, const std::string& indent, size_t width = 118) {
  std::string out;
  size_t at = text.find_first_not_of(' ');
  if (at == std::string::npos) return text;
  std::string line = text.substr(0, at);  // the first line keeps its own indentation
  const std::string first_indent = line;
  while (at < text.size()) {
    size_t end = text.find(' ', at);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(at, end - at);
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      out += line + "\n";
      line = indent;
    }
    if (word.empty()) {  // a run of spaces inside the text
      at = end + 1;
      continue;
    }
    line += (line == indent || line == first_indent ? "" : " ") + word;
    at = end + 1;
  }
  return out + line;
}

std::string num(double value, int digits = 4) { return value < 0 ? "-" : format_number(value, digits); }
// A whole count (cycles): every digit, no decimals ("85722", not "85722.0").
std::string count(double value) { return value < 0 ? "-" : std::to_string(uint64_t(std::llround(value))); }

// ops/ray, with the seed spread of a sampled builder: "24.85±0.31".
std::string ops_text(double mean, const Interval& spread) {
  if (spread.n < 2 || !std::isfinite(spread.half_width())) return num(mean);
  char half[32];
  std::snprintf(half, sizeof half, "%.2f", spread.half_width());
  return num(mean) + "±" + half;
}

// The registry's name, marked when the tree is not one of the patent's.
std::string display_name(const std::string& builder) {
  const BuilderInfo& info = builder_info(builder);
  return info.ours ? info.display_name + " (ours)" : info.display_name;
}

// "cold/warm": DRAM B/ray of the first frame and of the last, "-" without a cycle-level run.
std::string dram_cold_warm(const Table1Row& r) {
  if (r.combined.dram_bytes_per_ray < 0) return "-";
  return num(r.cold_dram_bytes_per_ray) + "/" + num(r.combined.dram_bytes_per_ray);
}

// A table whose columns can be left out: built row by row in full, then only the
// kept columns go into the TextTable.
struct Columns {
  std::vector<std::string> header;
  std::vector<bool> keep;
  std::vector<std::vector<std::string>> rows;
  void column(std::string name, bool kept = true) {
    header.push_back(std::move(name));
    keep.push_back(kept);
  }
  TextTable table() const {
    auto pick = [&](const std::vector<std::string>& cells) {
      std::vector<std::string> out;
      for (size_t i = 0; i < cells.size(); ++i)
        if (keep[i]) out.push_back(cells[i]);
      return out;
    };
    TextTable t(pick(header));
    for (const auto& r : rows) t.add_row(pick(r));
    return t;
  }
};

// A column "vs BASE" means something only if BASE is in the table with another
// builder to hold against it: not for a table of BASE alone, nor without BASE.
bool compares_against(const Table1& table, const std::string& camera, const std::string& base) {
  bool has_base = false, has_other = false;
  for (const Table1Row& r : table.rows)
    if (r.camera == camera) (r.builder == base ? has_base : has_other) = true;
  return has_base && has_other;
}

// The terminal's table per camera, within 120 columns: the Table 1 columns and
// the headline counts (camera_table has everything, for --wide and the files).
TextTable narrow_camera_table(const Table1& table, const std::string& camera) {
  const bool vs_median = compares_against(table, camera, "median"), vs_sah = compares_against(table, camera, "sah");
  const bool cycle = table.options.cycle_level;
  Columns c;
  c.column("builder"), c.column("ops/ray"), c.column("vs median", vs_median), c.column("vs SAH", vs_sah);
  c.column("TRV/ray"), c.column("IST/ray"), c.column("fetch/ray");
  c.column("DRAM B/ray cold/warm", cycle), c.column("cycles", cycle), c.column("build s");
  const Table1Row* median = table.find(camera, "median");
  const Table1Row* sah = table.find(camera, "sah");
  for (const Table1Row& r : table.rows) {
    if (r.camera != camera) continue;
    c.rows.push_back({display_name(r.builder), ops_text(r.combined.ops_per_ray, r.ops_combined),
                      median ? pct(r.combined.ops_per_ray, median->combined.ops_per_ray) : "-",
                      sah ? pct(r.combined.ops_per_ray, sah->combined.ops_per_ray) : "-",
                      num(r.combined.trv_per_ray), num(r.combined.ist_per_ray),
                      num(r.combined.node_fetches_per_ray),
                      dram_cold_warm(r),
                      count(r.cycles),
                      num(r.build_seconds + r.estimate_seconds, 3)});
  }
  return c.table();
}

// One table per camera: the Table 1 columns first, then what the patent does not show.
TextTable camera_table(const Table1& table, const std::string& camera) {
  const bool vs_median = compares_against(table, camera, "median"), vs_sah = compares_against(table, camera, "sah");
  const bool cycle = table.options.cycle_level;
  Columns c;
  c.column("builder"), c.column("ops/ray"), c.column("red. vs median", vs_median), c.column("red. vs SAH", vs_sah);
  const bool instanced = table.options.instanced;
  c.column("TRV/ray"), c.column("of them TLAS", instanced), c.column("IST/ray"), c.column("XFM/ray", instanced);
  c.column("box tests/ray"), c.column("primary ops/ray");
  c.column("AO ops/ray"), c.column("diffuse ops/ray", table.options.diffuse_bounces > 0);
  c.column("node fetches/ray"), c.column("fetch red. vs median", vs_median);
  c.column("fetch red. vs SAH", vs_sah), c.column("node B/tri"), c.column("DRAM B/ray cold/warm", cycle);
  c.column("cycles", cycle), c.column("pJ/ray", cycle), c.column("rays/J", cycle), c.column("build s");
  const Table1Row* median = table.find(camera, "median");
  const Table1Row* sah = table.find(camera, "sah");
  for (const Table1Row& r : table.rows) {
    if (r.camera != camera) continue;
    c.rows.push_back({display_name(r.builder), ops_text(r.combined.ops_per_ray, r.ops_combined),
                      median ? pct(r.combined.ops_per_ray, median->combined.ops_per_ray) : "-",
                      sah ? pct(r.combined.ops_per_ray, sah->combined.ops_per_ray) : "-",
                      num(r.combined.trv_per_ray), num(r.combined.tlas_trv_per_ray), num(r.combined.ist_per_ray),
                      num(r.combined.xfm_per_ray), num(r.combined.box_tests_per_ray),
                      ops_text(r.primary.ops_per_ray, r.ops_primary),
                      ops_text(r.ao.ops_per_ray, r.ops_ao), ops_text(r.diffuse.ops_per_ray, r.ops_diffuse),
                      num(r.combined.node_fetches_per_ray),
                      median ? pct(r.combined.node_fetches_per_ray, median->combined.node_fetches_per_ray) : "-",
                      sah ? pct(r.combined.node_fetches_per_ray, sah->combined.node_fetches_per_ray) : "-",
                      num(r.node_bytes_per_triangle, 3), dram_cold_warm(r),
                      count(r.cycles), num(r.combined.pj_per_ray, 5), num(r.rays_per_joule, 4),
                      num(r.build_seconds + r.estimate_seconds, 3)});
  }
  return c.table();
}

TextTable patent_table() {
  TextTable t({"viewpoint", "BVH", "SBVH", "OSAH", "AO-BVH"});
  const auto& p = patent_table1();
  for (int v = 0; v < 2; ++v) {
    auto cell = [&](int i) {
      const double value = v == 0 ? p[i].viewpoint1 : p[i].viewpoint2;
      const double base = v == 0 ? p[0].viewpoint1 : p[0].viewpoint2;
      return format_number(value) + " (" + pct(value, base) + ")";
    };
    t.add_row({"viewpoint " + std::to_string(v + 1), cell(0), cell(1), cell(2), cell(3)});
  }
  return t;
}

nlohmann::json interval_json(const Interval& i) {
  if (i.n < 2 || !std::isfinite(i.lo)) return nullptr;
  return {{"seeds", i.n}, {"mean", i.mean}, {"lo95", i.lo}, {"hi95", i.hi}};
}

// "N triangles", or for an instanced scene the unique and the placed.
std::string triangles_text(const Table1& table) {
  if (!table.instances) return std::to_string(table.triangles) + " triangles";
  return std::to_string(table.triangles) + " unique triangles, " + std::to_string(table.placed_triangles) +
         " placed by " + std::to_string(table.instances) + " instances";
}

nlohmann::json counts_json(const Table1Counts& c) {
  return {{"rays", c.rays},
          {"ops_per_ray", c.ops_per_ray},
          {"trv_ops_per_ray", c.trv_per_ray},
          {"ist_ops_per_ray", c.ist_per_ray},
          {"node_fetches_per_ray", c.node_fetches_per_ray},
          {"box_tests_per_ray", c.box_tests_per_ray},
          {"tlas_trv_ops_per_ray", c.tlas_trv_per_ray},
          {"xfm_ops_per_ray", c.xfm_per_ray},
          {"dram_bytes_per_ray", c.dram_bytes_per_ray < 0 ? nlohmann::json(nullptr)
                                                          : nlohmann::json(c.dram_bytes_per_ray)},
          {"pj_per_ray", c.pj_per_ray < 0 ? nlohmann::json(nullptr) : nlohmann::json(c.pj_per_ray)}};
}

}  // namespace

std::string patent_table1_text(bool markdown) {
  return markdown ? patent_table().markdown() : patent_table().plain();
}

std::string table1_cycle_runs_text(const Table1Options& o) {
  if (!o.cycle_level) return "No cycle-level runs (--no-cycle): no DRAM bytes, cycles or energy.";
  const bool preset = is_preset(o.hardware);
  char text[512];
  std::snprintf(text, sizeof text,
                "Cycle-level runs (DRAM bytes, cycles, energy): hardware %s '%s' (--config), %u frame%s of the "
                "same rays%s.",
                preset ? "preset" : "file", o.hardware.c_str(), o.frames, o.frames == 1 ? "" : "s",
                o.frames > 1 ? " (the first cold; figures of the last)" : "");
  return text;
}

std::vector<std::string> table1_figures(const Table1& table) {
  std::vector<std::string> out;
  bool compared = false;
  for (const std::string& camera : table.options.cameras)
    for (const char* base : {"median", "sah"}) compared |= compares_against(table, camera, base);
  if (compared) out.push_back("table1_reductions.png");
  out.push_back("table1_heatmaps.png");
  return out;
}

namespace {
// Whether any camera's table holds a builder against a baseline (the reductions' legend).
bool any_comparison(const Table1& table) {
  for (const std::string& camera : table.options.cameras)
    for (const char* base : {"median", "sah"})
      if (compares_against(table, camera, base)) return true;
  return false;
}
}  // namespace

std::string table1_text(const Table1& table, bool wide) {
  std::string out = "Table 1 on scene '" + table.scene_name + "' (" + triangles_text(table) +
                    ", node format " + table.options.node_format + ")\n" +
                    wrap(table1_cycle_runs_text(table.options), "") + "\n\n";
  if (table.options.patent_table_page.empty())
    out += "The patent's Table 1 (TRV+IST ops/ray, reduction against BVH):\n" + patent_table().plain() + "\n";
  const std::string legend = any_comparison(table) ? " (reductions: positive = fewer than the baseline)" : "";
  for (const std::string& camera : table.options.cameras)
    out += "Ours, camera " + camera + legend + ":\n" +
           (wide ? camera_table(table, camera) : narrow_camera_table(table, camera)).plain() + "\n";
  if (!wide) out += "(primary and AO ops/ray" + std::string(any_comparison(table) ? " and fetch reductions" : "") +
                    ": table1.md, or --wide)\n\n";
  if (!table.verdicts.empty()) {
    out += "Where the patent's ordering holds:\n";
    for (const std::string& v : table.verdicts) out += wrap("  - " + v, "    ") + "\n";
  }
  for (const Table1Row& r : table.rows)
    if (!r.counts_match_cycle_level)
      out += "  ! " + r.camera + "/" + r.builder +
             ": the cycle-level counts differ from the functional counts (a model bug)\n";
  out += "\n" + wrap("Counting rule and parameters: " + table.counting_rule, "") + "\n";
  return out;
}

void write_table1(const Table1& table) {
  const auto& dir = table.options.out_dir;
  std::string md = "# Table 1 on `" + table.scene_name + "` (" + triangles_text(table) +
                   ", node format `" + table.options.node_format + "`)\n\n" +
                   table1_cycle_runs_text(table.options) + "\n\n";
  if (table.options.patent_table_page.empty())
    md += "## The patent's Table 1\n\nTRV+IST operations per ray (reduction against BVH):\n\n" +
          patent_table().markdown() + "\n";
  else
    md += "The patent's Table 1 is on [" + table.options.patent_table_page + "](" + table.options.patent_table_page +
          ").\n\n";
  for (const std::string& camera : table.options.cameras)
    md += "## Ours, camera `" + camera + "`\n\n" +
          (any_comparison(table) ? "Reductions: positive = fewer than the baseline.\n\n" : "") +
          camera_table(table, camera).markdown() + "\n";
  if (!table.verdicts.empty()) {
    md += "## Where the patent's ordering holds\n\n";
    for (const std::string& v : table.verdicts) md += "- " + v + "\n";
    md += "\n";
  }
  md += "## Counting rule and parameters\n\n" + table.counting_rule + "\n\n";
  const std::vector<std::string> figures = table1_figures(table);
  for (const std::string& f : figures)
    md += "![" + std::string(f == "table1_reductions.png" ? "Reductions" : "Ops per pixel") + "](" + f + ")\n\n";
  write_file_atomic(dir / "table1.md", md);

  TextTable csv({"scene", "camera", "builder", "ray_type", "rays", "ops_per_ray", "trv_ops_per_ray",
                 "ist_ops_per_ray", "box_tests_per_ray", "node_fetches_per_ray", "dram_bytes_per_ray",
                 "cold_dram_bytes_per_ray", "cycles", "pj_per_ray", "rays_per_joule",
                 "build_seconds", "estimate_seconds", "sah_cost", "seeds", "ops_per_ray_lo95",
                 "ops_per_ray_hi95"});
  nlohmann::json json;
  json["scene"] = table.scene_name;
  json["triangles"] = table.triangles;
  if (table.instances) json["instances"] = table.instances, json["placed_triangles"] = table.placed_triangles;
  json["counting_rule"] = table.counting_rule;
  json["resolution"] = {table.options.width, table.options.height};
  json["ao_samples"] = table.ao_samples;
  json["diffuse_bounces"] = table.options.diffuse_bounces;
  json["opaque"] = table.options.opaque;
  json["instanced"] = table.options.instanced;
  json["ao_length"] = table.ao_length;
  json["hardware"] = table.options.hardware;
  json["node_format"] = table.options.node_format;
  json["frames"] = table.options.frames;
  json["cycle_level"] = table.options.cycle_level
                            ? nlohmann::json{{"hardware", table.options.hardware},
                                             {"kind", is_preset(table.options.hardware) ? "preset" : "file"},
                                             {"frames", table.options.frames},
                                             {"text", table1_cycle_runs_text(table.options)}}
                            : nlohmann::json(nullptr);
  json["figures"] = table1_figures(table);
  json["verdicts"] = table.verdicts;
  for (const auto& p : patent_table1())
    json["patent"][p.builder] = {{"viewpoint1", p.viewpoint1}, {"viewpoint2", p.viewpoint2}};
  for (const Table1Row& r : table.rows) {
    nlohmann::json row = {{"camera", r.camera},
                          {"builder", r.builder},
                          {"display_name", display_name(r.builder)},
                          {"seeds", r.seeds},
                          {"ops_per_ray_spread",
                           {{"combined", interval_json(r.ops_combined)},
                            {"primary", interval_json(r.ops_primary)},
                            {"ao", interval_json(r.ops_ao)},
                            {"diffuse", interval_json(r.ops_diffuse)}}},
                          {"cycles", r.cycles < 0 ? nlohmann::json(nullptr) : nlohmann::json(r.cycles)},
                          {"rays_per_joule", r.rays_per_joule < 0 ? nlohmann::json(nullptr)
                                                                  : nlohmann::json(r.rays_per_joule)},
                          {"cold_dram_bytes_per_ray", r.cold_dram_bytes_per_ray < 0
                                                          ? nlohmann::json(nullptr)
                                                          : nlohmann::json(r.cold_dram_bytes_per_ray)},
                          {"l1_node_hit_rate", r.l1_node_hit_rate},
                          {"l2_hit_rate", r.l2_hit_rate},
                          {"build_seconds", r.build_seconds},
                          {"estimate_seconds", r.estimate_seconds},
                          {"sah_cost", r.sah_cost},
                          {"nodes", r.nodes},
                          {"node_bytes_per_triangle", r.node_bytes_per_triangle},
                          {"counts_match_cycle_level", r.counts_match_cycle_level},
                          {"combined", counts_json(r.combined)},
                          {"primary", counts_json(r.primary)},
                          {"ao", counts_json(r.ao)},
                          {"diffuse", counts_json(r.diffuse)}};
    json["rows"].push_back(row);
    for (const auto& [type, c, spread] :
         {std::tuple<const char*, const Table1Counts*, const Interval*>{"combined", &r.combined, &r.ops_combined},
          {"primary", &r.primary, &r.ops_primary},
          {"ao", &r.ao, &r.ops_ao},
          {"diffuse", &r.diffuse, &r.ops_diffuse}}) {
      if (c == &r.diffuse && table.options.diffuse_bounces == 0) continue;  // no such rays
      const bool has_spread = spread->n > 1 && std::isfinite(spread->lo);
      csv.add_row({table.scene_name, r.camera, r.builder, type, std::to_string(c->rays),
                   format_number(c->ops_per_ray, 6), format_number(c->trv_per_ray, 6),
                   format_number(c->ist_per_ray, 6), format_number(c->box_tests_per_ray, 6),
                   format_number(c->node_fetches_per_ray, 6),
                   c->dram_bytes_per_ray < 0 ? "" : format_number(c->dram_bytes_per_ray, 6),
                   c != &r.combined || r.cold_dram_bytes_per_ray < 0 ? ""
                                                                     : format_number(r.cold_dram_bytes_per_ray, 6),
                   r.cycles < 0 ? "" : format_number(r.cycles, 9),
                   c->pj_per_ray < 0 ? "" : format_number(c->pj_per_ray, 6),
                   c != &r.combined || r.rays_per_joule < 0 ? "" : format_number(r.rays_per_joule, 6),
                   format_number(r.build_seconds, 4),
                   format_number(r.estimate_seconds, 4), format_number(r.sah_cost, 6),
                   std::to_string(r.seeds), has_spread ? format_number(spread->lo, 6) : "",
                   has_spread ? format_number(spread->hi, 6) : ""});
    }
  }
  write_file_atomic(dir / "table1.csv", csv.csv());
  write_file_atomic(dir / "table1.json", json.dump(2) + "\n");

  run_plot_script("table1_plots.py", {dir.string()});
}

std::string write_table1_formats(const std::vector<Table1>& tables,
                                 const std::filesystem::path& out_dir) {
  if (tables.empty()) return "";
  const Table1& first = tables.front();
  // "vs SAH" / "vs SBVH" only where that tree is there with others to compare.
  bool vs_sah = false, vs_sbvh = false;
  for (const std::string& camera : first.options.cameras)
    vs_sah |= compares_against(first, camera, "sah"), vs_sbvh |= compares_against(first, camera, "sbvh");
  const bool cycle = first.options.cycle_level;
  Columns c;
  c.column("camera"), c.column("builder"), c.column("format"), c.column("ops/ray"), c.column("vs SAH", vs_sah);
  c.column("vs SBVH", vs_sbvh), c.column("TRV/ray"), c.column("box tests/ray"), c.column("IST/ray");
  c.column("fetch/ray"), c.column("node B/tri"), c.column("DRAM B/ray", cycle), c.column("cycles", cycle);
  for (const std::string& camera : first.options.cameras)
    for (const Table1Row& base : first.rows) {
      if (base.camera != camera) continue;
      for (const Table1& table : tables) {
        const Table1Row* r = table.find(camera, base.builder);
        if (!r) continue;
        const Table1Row* sah = table.find(camera, "sah");
        const Table1Row* sbvh = table.find(camera, "sbvh");
        c.rows.push_back({camera, display_name(r->builder), table.options.node_format,
                          num(r->combined.ops_per_ray),
                          sah ? pct(r->combined.ops_per_ray, sah->combined.ops_per_ray) : "-",
                          sbvh ? pct(r->combined.ops_per_ray, sbvh->combined.ops_per_ray) : "-",
                          num(r->combined.trv_per_ray), num(r->combined.box_tests_per_ray),
                          num(r->combined.ist_per_ray), num(r->combined.node_fetches_per_ray),
                          num(r->node_bytes_per_triangle, 3), num(r->combined.dram_bytes_per_ray),
                          num(r->cycles, 6)});
      }
    }
  const TextTable t = c.table();
  // The finding: AO-BVH's relation to SAH and SBVH per width, and whether it turns.
  std::vector<std::string> findings;
  for (const std::string& camera : first.options.cameras)
    for (const char* base : {"sah", "sbvh"}) {
      std::string figures;
      int below = 0, measured = 0;
      for (const Table1& table : tables) {
        const Table1Row* ao = table.find(camera, "aobvh");
        const Table1Row* b = table.find(camera, base);
        if (!ao || !b) continue;
        ++measured;
        below += ao->combined.ops_per_ray < b->combined.ops_per_ray;
        figures += (figures.empty() ? "" : ", ") + pct(ao->combined.ops_per_ray, b->combined.ops_per_ray) +
                   " in " + table.options.node_format;
      }
      if (measured == 0) continue;
      const std::string verdict = below == measured ? "below it in every format"
                                  : below == 0      ? "not below it in any format"
                                                    : "below it in " + std::to_string(below) + " of " +
                                                          std::to_string(measured) + " formats: the relation turns with the width";
      findings.push_back("Camera " + camera + ": AO-BVH against " + display_name(base) + ": " + figures +
                         " fewer ops/ray; " + verdict + ".");
    }
  const std::string reductions = vs_sah || vs_sbvh ? "Reductions: positive = fewer ops/ray than the SAH (or SBVH) "
                                                     "tree in the same format. "
                                                   : "";
  std::string md = "# Table 1 on `" + first.scene_name + "` by node format\n\n" +
                   table1_cycle_runs_text(first.options) + "\n\n## The patent's Table 1\n\n"
                   "TRV+IST operations per ray (reduction against BVH), shown here once for every format:\n\n" +
                   patent_table().markdown() + "\n## Ours by node format\n\n" + reductions +
                   "Each format's own folder has its full Table 1 and counting rule.\n\n" + t.markdown() + "\n";
  if (!findings.empty()) {
    md += "## Does AO-BVH's relation to SAH and SBVH change with the width?\n\n";
    for (const std::string& f : findings) md += "- " + f + "\n";
    md += "\n";
  }
  md += "![By format](table1_formats.png)\n";
  write_file_atomic(out_dir / "formats.md", md);
  write_file_atomic(out_dir / "formats.csv", t.csv());
  std::vector<std::string> args = {out_dir.string(), "--formats"};
  for (const Table1& table : tables) args.push_back(table.options.node_format);
  run_plot_script("table1_plots.py", args);
  std::string text = "Table 1 on '" + first.scene_name + "' by node format" +
                     (vs_sah || vs_sbvh ? " (reductions against SAH and SBVH in the same format)" : "") + "\n" +
                     wrap(table1_cycle_runs_text(first.options), "") +
                     "\n\nThe patent's Table 1 (TRV+IST ops/ray, reduction against BVH):\n" + patent_table().plain() +
                     "\nOurs:\n" + t.plain();
  if (!findings.empty()) {
    text += "\nDoes AO-BVH's relation to SAH and SBVH change with the width?\n";
    for (const std::string& f : findings) text += wrap("  - " + f, "    ") + "\n";
  }
  return text;
}

}  // namespace rtsim
