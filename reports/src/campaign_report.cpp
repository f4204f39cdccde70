// The campaign report: data for the plot script, then Markdown and HTML around it.
#include <rtsim/reports/campaign.h>
#include <rtsim/reports/campaign_report.h>

#include <rtsim/builder/builder_registry.h>
#include <rtsim/builder/bvh_file.h>
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stat_names.h>
#include <rtsim/reports/plot_script.h>
#include <rtsim/reports/results_store.h>
#include <rtsim/reports/text_table.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/numbers.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace rtsim {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The stats the figures read; the full stats.json stays in the database.
bool wanted_stat(const std::string& path) {
  for (const char* prefix : {"dram.", "per_type.", "l1_node.all.", "l1_triangle.all.", "l2.",
                             "time.", "ops.", "fetches.", "rays.", "energy.", "noc.", "machine."})
    if (path.rfind(prefix, 0) == 0) return true;
  return false;
}

double number_or_nan(const json& v) { return v.is_number() ? v.get<double>() : NAN; }

std::string cell(const json& v, int digits = 4) {
  return v.is_number() ? format_number(v.get<double>(), digits) : std::string("-");
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// A swept axis of the campaign: a hardware key (an override, cores included), a
// builder parameter (build.KEY), the node format, or an axis of the workload, with its
// unit. A workload axis has a plain value: the run at it is the plain run.
struct Coordinate {
  std::string key, unit;
  enum Kind { Hardware, Build, NodeFormat, Workload } kind;
  json plain = nullptr;
};

// The workload's axes (campaign.cpp's), with simulate's default where it is a fixed
// value (absent: the scene decides). Seeds are replicates: their plain run is seed 1
// and their figure shows the spread.
struct WorkloadAxis {
  const char* key;
  const char* unit;
  json absent;  // the value of a job that does not set it
};
const WorkloadAxis kWorkloadAxes[] = {{"camera", "", nullptr},
                                      {"seed", "", 1},
                                      {"ao", "AO rays per hit", nullptr},
                                      {"ao_cutoff", "x scene diagonal", nullptr},
                                      {"frames", "frames", 1},
                                      {"diffuse_bounces", "bounces", 0},
                                      {"opaque", "", false},
                                      {"instanced", "", false},
                                      {"resolution", "pixels", nullptr}};

std::string hardware_unit(const std::string& key) {
  sim::HardwareConfig config;
  std::string unit;
  sim::for_each_parameter(config, [&](sim::ParameterInfo& p) {
    if (p.key == key) unit = p.unit;
  });
  return unit;
}

// A value as the campaign wrote it, as a number where it is one ("524288" -> 524288).
json typed(const json& text) {
  if (!text.is_string()) return text;
  const json number = json::parse(text.get<std::string>(), nullptr, false);
  return number.is_number() ? number : text;
}

// A job's value of a workload axis: a number (a resolution as its pixel count), or
// the axis's value when the job leaves it out.
json workload_value(const json& job, const WorkloadAxis& axis) {
  if (!job.contains(axis.key)) return axis.absent;
  const json text = job.at(axis.key);
  uint32_t w = 0, h = 0;
  if (std::string(axis.key) == "resolution" && text.is_string() && parse_resolution_text(text.get<std::string>(), w, h))
    return uint64_t(w) * h;
  return typed(text);
}

// Every axis the campaign sweeps besides scene, builder, preset and fidelity.
std::vector<Coordinate> swept_coordinates(const std::vector<json>& jobs) {
  std::map<std::string, Coordinate> found;
  for (const json& job : jobs) {
    const json set = job.value("set", json::object()), build = job.value("build", json::object());
    for (const auto& [k, v] : set.items())
      found.emplace(k, Coordinate{k, hardware_unit(k), Coordinate::Hardware});
    for (const auto& [k, v] : build.items()) {
      const BuilderParameter* p = find_builder_parameter(k);
      found.emplace("build." + k, Coordinate{"build." + k, p ? p->unit : "", Coordinate::Build});
    }
    if (job.contains("node_format")) found.emplace("node_format", Coordinate{"node_format", "", Coordinate::NodeFormat});
  }
  // The node format set as an override is the node format axis.
  if (found.count("memory.node_format")) {
    found.erase("memory.node_format");
    found.emplace("node_format", Coordinate{"node_format", "", Coordinate::NodeFormat});
  }
  // A workload axis with more than one value: the plain run is at simulate's default
  // where some job has it, else at the axis's smallest value, so that the main figures
  // show one run per builder and preset, not whichever value came last.
  for (const WorkloadAxis& axis : kWorkloadAxes) {
    std::set<json> values;
    for (const json& job : jobs) values.insert(workload_value(job, axis));
    if (values.size() < 2) continue;
    Coordinate c{axis.key, axis.unit, Coordinate::Workload};
    c.plain = values.count(axis.absent) ? axis.absent : *values.begin();
    found.emplace(axis.key, c);
  }
  std::vector<Coordinate> out;
  for (auto& [k, c] : found) out.push_back(c);
  return out;
}

// A run's value of each coordinate, its default where the job left it: the preset's
// (the run's hardware) or the builder's.
json coordinate_values(const std::vector<Coordinate>& coordinates, const json& job, const json& hardware,
                       const std::string& builder) {
  json out = json::object();
  for (const Coordinate& c : coordinates) {
    json value;
    if (c.kind == Coordinate::Hardware) {
      if (const json* v = json_at_path(hardware, c.key)) value = *v;
    } else if (c.kind == Coordinate::NodeFormat) {
      if (const json* v = json_at_path(hardware, "memory.node_format")) value = *v;
    } else if (c.kind == Coordinate::Workload) {
      for (const WorkloadAxis& axis : kWorkloadAxes)
        if (c.key == axis.key) value = workload_value(job, axis);
    } else {
      const std::string key = c.key.substr(6);
      const json set = job.value("build", json::object());
      if (set.contains(key)) {
        value = typed(set.at(key));
      } else {
        BuildParams plain;
        plain.builder = builder;
        value = json::parse(build_params_json(plain)).value(key, json());
        if (key == "seed") value = typed(job.value("seed", json()));  // the workload's
      }
    }
    out[c.key] = value;
  }
  return out;
}

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

// Leaves out the columns every row has the same value in (one builder, one preset):
// returns them as "header value" pairs for the text above the table.
std::vector<std::string> drop_constant_columns(Table& t, size_t first_droppable, size_t last_droppable) {
  std::vector<std::string> constant;
  if (t.rows.size() < 2) return constant;
  for (size_t c = std::min(last_droppable, t.header.size() - 1) + 1; c-- > first_droppable;) {
    bool same = true;
    for (const auto& row : t.rows) same = same && row[c] == t.rows.front()[c];
    if (!same) continue;
    constant.insert(constant.begin(), t.header[c] + " " + t.rows.front()[c]);
    t.header.erase(t.header.begin() + ptrdiff_t(c));
    for (auto& row : t.rows) row.erase(row.begin() + ptrdiff_t(c));
  }
  return constant;
}

std::string html_table(const Table& t) {
  std::string out = "<table>\n<tr>";
  for (const std::string& h : t.header) out += "<th>" + html_escape(h) + "</th>";
  out += "</tr>\n";
  for (const auto& row : t.rows) {
    out += "<tr>";
    for (const std::string& c : row) out += "<td>" + html_escape(c) + "</td>";
    out += "</tr>\n";
  }
  return out + "</table>\n";
}

std::string markdown_table(const Table& t) {
  TextTable table(t.header);
  for (const auto& row : t.rows) table.add_row(row);
  return table.markdown();
}

}  // namespace

CampaignReportFiles write_campaign_report(const CampaignReportOptions& options) {
  if (!is_file(options.database))
    throw InputError(options.database.string(), "no such results database");
  std::vector<json> rows;
  std::vector<std::string> campaigns;
  {
    ResultsStore store(options.database, ResultsStore::Access::ReadOnly);
    rows = store.rows(options.campaign);
    campaigns = options.campaign.empty() ? store.campaigns()
                                         : std::vector<std::string>{options.campaign};
  }
  if (rows.empty())
    throw InputError(options.database.string(),
                     options.campaign.empty() ? "holds no runs"
                                              : "holds no runs of campaign '" + options.campaign + "'");
  fs::create_directories(options.out_dir);

  // Data for the plot script, one entry per run.
  json runs = json::array();
  std::set<std::string> revisions;
  std::vector<json> jobs;
  for (const json& row : rows) jobs.push_back(json::parse(row.value("job_json", std::string("{}")), nullptr, false));
  const std::vector<Coordinate> coordinates = swept_coordinates(jobs);
  for (size_t i = 0; i < rows.size(); ++i) {
    const json& row = rows[i];
    const json& job = jobs[i].is_object() ? jobs[i] : json::object();
    json run;
    for (const char* k : {"campaign", "job_key", "label", "group_name", "status", "error", "scene",
                          "builder", "camera", "preset", "fidelity", "git_revision"})
      run[k] = row.value(k, json(""));
    revisions.insert(row.value("git_revision", std::string()));
    run["overrides"] = json::parse(row.value("overrides", std::string("{}")));
    const json config = json::parse(row.value("config_json", std::string("null")));
    run["hardware"] = config.is_object() ? config.value("hardware", json::object()) : json::object();
    run["coordinates"] = coordinate_values(coordinates, job, run["hardware"], row.value("builder", std::string()));
    // The plain run: every coordinate at its default (the campaign drops values equal to it).
    bool plain_workload = true;
    for (const Coordinate& c : coordinates)
      if (c.kind == Coordinate::Workload) plain_workload = plain_workload && run["coordinates"][c.key] == c.plain;
    run["plain"] = !job.contains("node_format") && job.value("set", json::object()).empty() &&
                   job.value("build", json::object()).empty() && plain_workload;
    json headline = json::object();
    for (const auto& [name, unit] : ResultsStore::headline_columns()) headline[name] = row[name];
    headline["host_seconds"] = row["host_seconds"];
    run["headline"] = headline;
    json stats = json::object();
    for (const auto& [path, value] :
         flatten_stats(json::parse(row.value("stats_json", std::string("null")))))
      if (wanted_stat(path) && std::isfinite(value)) stats[path] = value;
    run["stats"] = stats;
    runs.push_back(run);
  }
  std::string title = "Campaign report: ";
  for (size_t i = 0; i < campaigns.size(); ++i) title += (i ? ", " : "") + campaigns[i];

  json axes = json::array();
  for (const Coordinate& c : coordinates) {
    std::set<json> values;
    for (const json& r : runs) values.insert(r["coordinates"][c.key]);
    axes.push_back({{"key", c.key}, {"unit", c.unit}, {"values", std::vector<json>(values.begin(), values.end())}});
  }
  CampaignReportFiles files;
  files.data = options.out_dir / "report-data.json";
  write_file_atomic(files.data, json{{"title", title},
                                     {"names", sim::vocabulary_json()},
                                     {"coordinates", axes},
                                     {"runs", runs}}
                                        .dump(1) +
                                    "\n");

  // The headline table: grouped by scene, fidelity and overrides, then preset, then
  // builders in order of DRAM bytes per ray, so neighbouring rows differ in one thing.
  std::vector<const json*> ok, failed;
  for (const json& r : runs) (r["status"] == "ok" ? ok : failed).push_back(&r);
  // Coordinates compare as values (numbers as numbers: 262144 before 1048576).
  std::sort(ok.begin(), ok.end(), [](const json* a, const json* b) {
    auto key = [](const json* r) {
      return std::make_tuple((*r)["scene"].get<std::string>(), (*r)["fidelity"].get<std::string>(),
                             (*r)["coordinates"], (*r)["preset"].get<std::string>(),
                             number_or_nan((*r)["headline"]["dram_bytes_per_ray"]),
                             (*r)["builder"].get<std::string>());
    };
    return key(a) < key(b);
  });
  Table results;
  results.header = {"scene",       "fidelity",        "preset",          "swept",
                    "builder",     "cycles",          "ops/ray",         "TRV ops/ray",
                    "IST ops/ray", "node fetches/ray", "DRAM bytes/ray", "L1 node hit",
                    "L1 tri hit",  "L2 hit",          "pJ/ray",          "rays/J",
                    "host s",      "rays/host s"};
  for (const json* r : ok) {
    const json& h = (*r)["headline"];
    std::string swept;
    for (auto it = (*r)["coordinates"].begin(); it != (*r)["coordinates"].end(); ++it)
      swept += (swept.empty() ? "" : " ") + it.key() + "=" +
               (it.value().is_string() ? it.value().get<std::string>() : it.value().dump());
    results.rows.push_back({(*r)["scene"], (*r)["fidelity"], (*r)["preset"],
                            swept.empty() ? "-" : swept, (*r)["builder"], cell(h["cycles"], 6),
                            cell(h["ops_per_ray"]), cell(h["trv_ops_per_ray"]),
                            cell(h["ist_ops_per_ray"]), cell(h["node_fetches_per_ray"]),
                            cell(h["dram_bytes_per_ray"]), cell(h["l1_node_hit_rate"], 3),
                            cell(h["l1_triangle_hit_rate"], 3), cell(h["l2_hit_rate"], 3),
                            cell((*r)["stats"].value("energy.pj_per_ray", json())),
                            cell((*r)["stats"].value("energy.rays_per_joule", json()), 3),
                            cell(h["host_seconds"], 3), cell(h["rays_per_host_second"], 3)});
  }
  Table failures;
  failures.header = {"job", "key", "error"};
  for (const json* r : failed) {
    // The reason (first line) and the log's last line, which usually says why.
    const std::string full = (*r)["error"];
    std::string error = full.substr(0, full.find('\n'));
    const size_t last = full.find_last_of('\n');
    if (last != std::string::npos) error += ": " + full.substr(last + 1);
    failures.rows.push_back({(*r)["label"], (*r)["job_key"], error});
  }

  // Figures (after the data and before the text, so a failing script leaves the data).
  json figures = json::array();
  if (options.figures && !ok.empty()) {
    run_plot_script("campaign_plots.py", {files.data.string(), options.out_dir.string()});
    std::ifstream in(options.out_dir / "figures.json");
    figures = json::parse(in);
    for (const json& f : figures) files.figures.push_back(options.out_dir / f["file"].get<std::string>());
  }

  // What every row shares goes above the table, not in a column of equal cells.
  const std::vector<std::string> shared = drop_constant_columns(results, 0, 4);
  std::set<std::string> builders;
  for (const json* r : ok) builders.insert((*r)["builder"].get<std::string>());
  std::string revision_text;
  for (const std::string& r : revisions) revision_text += (revision_text.empty() ? "" : ", ") + r;
  std::string shared_text;
  for (const std::string& c : shared) shared_text += (shared_text.empty() ? "" : ", ") + c;
  const std::string summary = std::to_string(runs.size()) + " runs (" + std::to_string(ok.size()) +
                              " ok, " + std::to_string(failed.size()) + " failed) from " +
                              options.database.filename().string() + ", rtsim revision " +
                              revision_text + "." + (shared_text.empty() ? "" : " Every run: " + shared_text + ".");
  std::string reading =
      builders.size() > 1
          ? "Figures: builders are sorted by DRAM bytes per ray (mean over presets) and each "
            "preset has its own bar, so the difference between builders reads left to right and "
            "the difference between presets within each group. "
          : "";
  if (!coordinates.empty())
    reading += "Each swept axis has its own figure: cycles, DRAM bytes, energy per ray and TRV "
               "utilisation against the axis's value" +
               std::string(builders.size() > 1 ? ", one column of panels per builder" : "") +
               "; a run at the default value (no override, or one equal to the preset's; a workload "
               "axis such as AO rays or diffuse bounces at simulate's default, else at its smallest "
               "value) is the plain run and a point of every sweep. ";
  reading += "Every row's full config.json and stats.json are in the database.";

  std::ostringstream md;
  md << "# " << title << "\n\n" << summary << "\n\n" << reading << "\n\n";
  int n = 0;
  for (const json& f : figures) {
    ++n;  // numbered apart from the stream: clearer, and no -Wsequence-point
    md << "## Figure " << n << ": " << f["title"].get<std::string>() << "\n\n![" << f["title"].get<std::string>()
       << "](" << f["file"].get<std::string>() << ")\n\n*Figure " << n << ": "
       << f["caption"].get<std::string>() << "*\n\n";
  }
  md << "## Results\n\nHit rates are fractions; host seconds are the job's wall time "
        "including loading and building the tree.\n\n"
     << markdown_table(results) << "\n";
  if (!failures.rows.empty()) md << "## Failed jobs\n\n" << markdown_table(failures) << "\n";
  files.markdown = options.out_dir / "report.md";
  write_file_atomic(files.markdown, md.str());

  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" << html_escape(title)
       << "</title>\n<style>body{font-family:sans-serif;max-width:1300px;margin:2em auto;"
          "padding:0 1em}table{border-collapse:collapse;font-size:12px}td,th{border:1px solid "
          "#ccc;padding:2px 6px;text-align:right}th{background:#eee}td:nth-child(-n+5){text-"
          "align:left}figure{margin:2em 0}img{max-width:100%}figcaption{font-style:italic}"
          "</style></head><body>\n<h1>"
       << html_escape(title) << "</h1>\n<p>" << html_escape(summary) << "</p>\n<p>"
       << html_escape(reading) << "</p>\n";
  n = 0;
  for (const json& f : figures) {
    ++n;
    html << "<figure><img src=\"" << html_escape(f["file"].get<std::string>()) << "\" alt=\""
         << html_escape(f["title"].get<std::string>()) << "\"><figcaption>Figure " << n << ": "
         << html_escape(f["caption"].get<std::string>()) << "</figcaption></figure>\n";
  }
  html << "<h2>Results</h2>\n" << html_table(results);
  if (!failures.rows.empty()) html << "<h2>Failed jobs</h2>\n" << html_table(failures);
  html << "</body></html>\n";
  files.html = options.out_dir / "report.html";
  write_file_atomic(files.html, html.str());
  return files;
}

}  // namespace rtsim
