#include <rtsim/reports/stats_reference.h>

#include <rtsim/model/core/fetch.h>
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/ray_dispatch.h>
#include <rtsim/reports/results_store.h>
#include <rtsim/reports/simulation_job.h>
#include <rtsim/workloads/files.h>

#include <algorithm>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>

namespace rtsim {

using nlohmann::json;

namespace {

// Every leaf {value, unit, description} by dotted path.
void leaves(const json& node, const std::string& prefix, std::map<std::string, std::pair<std::string, std::string>>& out) {
  if (node.is_object() && node.contains("value") && node.contains("unit")) {
    out[prefix] = {node.at("unit").get<std::string>(), node.value("description", std::string())};
    return;
  }
  if (!node.is_object()) return;
  for (auto it = node.begin(); it != node.end(); ++it)
    leaves(it.value(), prefix.empty() ? it.key() : prefix + "." + it.key(), out);
}

std::string replace_word(const std::string& text, const std::string& word, const std::string& with) {
  return std::regex_replace(text, std::regex("\\b" + word + "\\b"), with);
}

// The name with its instance numbers, ray type and byte kind as placeholders, and the
// description with the same words folded.
std::pair<std::string, std::string> fold(const std::string& path, std::string description) {
  static const std::vector<std::pair<std::regex, std::string>> instances = {
      {std::regex("core[0-9]+"), "core<c>"},     {std::regex("trv[0-9]+"), "trv<u>"},
      {std::regex("ist[0-9]+"), "ist<i>"},       {std::regex("l1_node[0-9]+"), "l1_node<u>"},
      {std::regex("l1_triangle[0-9]+"), "l1_triangle<i>"}, {std::regex("slice[0-9]+"), "slice<s>"},
      {std::regex("frame[0-9]+"), "frame<k>"}};
  std::vector<std::string> parts;
  std::stringstream in(path);
  for (std::string p; std::getline(in, p, '.');) parts.push_back(p);
  for (size_t i = 0; i < parts.size(); ++i) {
    for (const auto& [re, placeholder] : instances)
      if (std::regex_match(parts[i], re)) parts[i] = placeholder;
    for (RayType t : kAllRayTypes)
      if (parts[i] == ray_type_name(t)) {
        parts[i] = "<type>";
        description = replace_word(description, ray_type_name(t), "<type>");
      }
    // A byte kind is a placeholder where it follows a ray type (bytes by type and kind).
    if (i > 0 && parts[i - 1] == "<type>")
      for (int k = 0; k < kAccessKindCount; ++k)
        if (parts[i] == access_kind_name(AccessKind(k))) {
          parts[i] = "<kind>";
          description = replace_word(description, access_kind_name(AccessKind(k)), "<kind>");
        }
  }
  std::string out;
  for (const std::string& p : parts) out += (out.empty() ? "" : ".") + p;
  return {out, description};
}

}  // namespace

std::vector<StatReferenceRow> stats_reference(const std::vector<std::pair<std::string, json>>& runs) {
  std::map<std::string, StatReferenceRow> rows;
  for (const auto& [level, stats] : runs) {
    std::map<std::string, std::pair<std::string, std::string>> all;
    leaves(stats, "", all);
    for (const auto& [path, unit_description] : all) {
      const auto [pattern, description] = fold(path, unit_description.second);
      auto [it, fresh] = rows.emplace(pattern, StatReferenceRow{pattern, unit_description.first, description, {}});
      StatReferenceRow& row = it->second;
      if (!fresh && (row.unit != unit_description.first || row.description != description))
        throw std::runtime_error("the statistic " + pattern + " has two meanings: [" + row.unit + "] " +
                                 row.description + " / [" + unit_description.first + "] " + description +
                                 " (at " + path + ", " + level + ")");
      if (std::find(row.levels.begin(), row.levels.end(), level) == row.levels.end()) row.levels.push_back(level);
    }
  }
  std::vector<StatReferenceRow> out;
  for (auto& [pattern, row] : rows) out.push_back(row);
  return out;
}

std::string stats_reference_markdown(const std::vector<StatReferenceRow>& rows, const std::string& how_made) {
  std::ostringstream md;
  md << "# Statistics\n\n"
     << "Every statistic `rtsim simulate` writes to `stats.json`, with the unit and the description the "
        "model gives it (each value in the file carries both). Generated, not written: `" << how_made
     << "` makes this page from the stats of runs at every fidelity level, and a test keeps it equal "
        "(`tests/integration/test_stats_reference.cpp`). Placeholders stand for instances and names: "
        "`core<c>` a core, `trv<u>` / `l1_node<u>` a TRV unit and its L1, `ist<i>` / `l1_triangle<i>` an IST "
        "unit and its L1, `slice<s>` an L2 slice, `frame<k>` a frame, `<type>` a ray type ("
     << [] {
          std::string t;
          for (RayType r : kAllRayTypes) t += (t.empty() ? "" : ", ") + std::string(ray_type_name(r));
          return t;
        }()
     << ") and `<kind>` a byte kind ("
     << [] {
          std::string k;
          for (int i = 0; i < kAccessKindCount; ++i) k += (k.empty() ? "" : ", ") + std::string(access_kind_name(AccessKind(i)));
          return k;
        }()
     << "). These names are declared once in the model (`model/include/rtsim/model/sim/stat_names.h`) and "
        "the reports and plot scripts read them from there.\n\n"
     << "## Identities\n\n"
     << "The numbers add up; the tests named check each.\n\n"
     << "- **Cycle accounting** (`model/include/rtsim/model/sim/accounting.h`): every TRV, IST and shading "
        "unit is in exactly one state at every moment, so its `<state>_cycles` add up to `time.cycles` "
        "(`test_accounting.cpp`, and the timeline's spans to the same figures: `test_timeline.cpp`). The "
        "state is the first that holds of: ";
  for (sim::CycleBucket b : sim::kAllCycleBuckets)
    md << (b == sim::CycleBucket::Busy ? "" : "; ") << "`" << sim::cycle_bucket_name(b) << "` ("
       << sim::cycle_bucket_meaning(b) << ")";
  md << ". Deepest level first, as the top-down method charges a stalled cycle to the farthest level "
        "with a miss outstanding. TRV units have every state, IST units all but `blocked` and "
        "`waiting_ist`, shading `busy`, `latency` and `idle`. At the lt level a leaf's triangle "
        "reads are issued in its TRV unit's step, so their wait is the TRV's `waiting_ist` and the IST "
        "unit shows no memory waits (the cycle level's IST unit reads them itself). `utilisation` = "
        "`busy_cycles` / "
        "`time.cycles`; `machine.<kind>.<state>_cycles.{mean,min,max}` are over the machine's units of a "
        "kind. With `stats.accounting = \"off\"` none of these is reported and every other stat is "
        "the same (`test_accounting.cpp`).\n"
     << "- `per_type.<type>.trv_busy_cycles` summed over the ray types is the TRV units' `busy_cycles` "
        "summed (to a cycle per unit), and the same for IST.\n"
     << "- A cache's `accesses` = `hits` + `misses` + `mshr_merges`; `hit_rate` = `hits` / `accesses`.\n"
     << "- `dram.bytes` = `dram.bytes_by_type.total` = the sum of `dram.bytes_by_type.<type>.<kind>` (every "
        "byte read from DRAM is an L2 fill, charged to the ray type and byte kind of the miss; a dirty "
        "line written back is charged to the ray type that wrote it); `dram.bytes_per_ray` = `dram.bytes` "
        "/ `rays.total`. The report's DRAM figure stacks exactly these (`test_report_figures.cpp`).\n"
     << "- `energy.total_pj` = the sum of `energy.<component>.pj` over the dynamic components (TRV, IST, "
        "the caches, the crossbar, the DRAM's commands, and the optional stages where they are built), and `energy.pj_per_ray` of "
        "`energy.<component>.pj_per_ray`; the DRAM's standby energy `energy.dram_background` is beside the "
        "total, not in it: `energy.pj_per_ray_with_background` = `energy.pj_per_ray` + "
        "`energy.dram_background.pj_per_ray`.\n"
     << "- `ops.per_ray` = (`ops.trv` + `ops.ist`) / `rays.total`, and per ray type the same.\n"
     << "- `<cache>.amat` is the mean, over the reads of the level, of the cycles from a read reaching it to "
        "its data leaving it; `amat_by_type.<type>` the same for one ray type's reads (lt and cycle).\n\n"
     << "## Every statistic\n\n"
     << "| statistic | unit | levels | description |\n|---|---|---|---|\n";
  for (const StatReferenceRow& r : rows) {
    std::string levels;
    for (const std::string& l : r.levels) levels += (levels.empty() ? "" : ", ") + l;
    std::string description = r.description;
    for (size_t at = 0; (at = description.find('|', at)) != std::string::npos; at += 2) description.replace(at, 1, "\\|");
    md << "| `" << r.pattern << "` | " << r.unit << " | " << levels << " | " << description << " |\n";
  }
  return md.str();
}

std::string make_stats_reference(const std::filesystem::path& binary, const std::filesystem::path& work_dir) {
  std::filesystem::create_directories(work_dir);
  const std::filesystem::path machine = work_dir / "machine.toml";
  // Small L1s: the second frame still reaches the L2 and DRAM (their latencies). Every
  // optional stage, each as its description builds it, so its stats are listed too.
  std::string machine_text = "preset = \"mobile-gpu\"\ncores = 2\nl1_node.size_bytes = 1024\n"
                             "l1_triangle.size_bytes = 1024\n";
  for (const rtsim::sim::StageDescription& stage : rtsim::sim::RayDispatcher::stage_kinds())
    machine_text += stage.config_lines;
  write_file_atomic(machine, machine_text);
  const JobRunner runner(binary);
  std::vector<std::pair<std::string, json>> runs;
  for (const char* level : {"functional", "lt", "cycle"}) {
    SimulationJob job;
    job.scene = "cornell";  // a light: shadow rays and shading; AO
    job.fidelity = level;
    job.config = machine.string();
    job.resolution = "16x16";
    job.frames = 2;
    job.out_dir = work_dir / level;
    runs.emplace_back(level, runner.simulate(job, work_dir / (std::string(level) + ".log")).stats);
    // The stats only some workloads have: the any-hit stage (alpha-tested leaves) and
    // the two-level tree's TLAS, BLAS and XFM counts (an instanced forest).
    for (const char* scene : {"foliage_alpha", "forest_instanced"}) {
      SimulationJob extra = job;
      extra.scene = scene;
      extra.instanced = std::string(scene) == "forest_instanced";
      extra.frames = 1;
      extra.out_dir = work_dir / (std::string(level) + "-" + scene);
      runs.emplace_back(level, runner.simulate(extra, work_dir / (std::string(level) + "-" + scene + ".log")).stats);
    }
  }
  return stats_reference_markdown(stats_reference(runs), "rtsim stats-reference --out docs/stats.md");
}

}  // namespace rtsim
