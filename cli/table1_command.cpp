// rtsim table1: the patent's Table 1 on a scene's two cameras (the README's main job).
#include "build_options.h"
#include "cli_util.h"
#include "commands.h"

#include <rtsim/reports/child_process.h>
#include <rtsim/reports/table1.h>
#include <rtsim/reports/text_table.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/fetch.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/scene_registry.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>

namespace rtsim::cli {

namespace {

struct Table1CommandOptions {
  Table1Options table;
  std::string resolution = kDefaultResolution;
  std::vector<std::string> node_formats = {"bvh2-64"};
  bool all_scenes = false, no_cycle = false, json = false, wide = false;
};

Table1 run_one(Table1Options options, bool print, bool wide) {
  const Table1 table = run_table1(options);
  write_table1(table);
  if (print) std::fputs(table1_text(table, wide).c_str(), stdout);
  std::fflush(stdout);  // the table first, then the note on stderr, not interleaved
  std::string figures;
  for (const std::string& f : table1_figures(table)) figures += ", " + f;
  std::fprintf(stderr, "wrote %s/table1.{md,csv,json}%s\n", options.out_dir.string().c_str(), figures.c_str());
  return table;
}

void run_all_scenes(const Table1CommandOptions& o) {
  std::vector<std::string> scenes = {default_scene_name()};
  for (const RealSceneInfo& info : real_scene_catalogue())
    if (std::filesystem::exists(scene_cache_dir() / info.name / "scene.toml")) scenes.push_back(info.name);
  if (scenes.size() == 1)
    std::fprintf(stderr, "no real scene is fetched yet (rtsim scenes fetch all); running the default only\n");
  if (o.table.instanced) {
    // The scenes that have instances, and the generated forest (its 50M-triangle
    // twin would need its flat form, 9 GB, for AO-BVH's estimates).
    std::vector<std::string> kept = {"forest_instanced"};
    for (const std::string& scene : scenes)
      if (load_scene(scene, SceneForm::Instanced).instanced()) kept.push_back(scene);
      else std::fprintf(stderr, "table1 --instanced: %s has no instances; left out\n", scene.c_str());
    scenes = kept;
  }
  // Each relation of the patent's ordering on its own, for each reading of its
  // AO-BVH (object, spatial): the whole ordering can fail on one relation while the
  // others hold everywhere, and the summary should show which. The wide form has
  // each relation in its own column; the terminal's (120 columns) names the
  // relations that fail (a trailing ~: unresolved by the seed spread).
  const std::vector<std::string> trees = {"median", "sah", "sbvh", "osah", "aobvh", "aosbvh"};
  const std::vector<std::pair<std::string, std::string>> readings = {{"aobvh", "obj"}, {"aosbvh", "spat"}};
  std::vector<std::string> wide_header = {"scene", "camera"};
  for (const std::string& b : trees) wide_header.push_back(b);
  for (const auto& [reading, tag] : readings)
    for (const char* rel : {"all < median", "AO < OSAH", "AO < SBVH", "AO < SAH"})
      wide_header.push_back(tag + ": " + rel);
  std::vector<std::string> narrow_header = {"scene", "camera"};
  for (const std::string& b : trees) narrow_header.push_back(b);
  narrow_header.push_back("ordering fails (obj | spat)");
  TextTable summary(o.wide ? wide_header : narrow_header);
  TextTable summary_wide(wide_header);
  for (const std::string& scene : scenes) {
    Table1Options options = o.table;
    options.scene = scene;
    options.out_dir = o.table.out_dir / scene;
    options.patent_table_page = "../summary.md";  // once, above every scene
    const Table1 table = run_one(options, false, o.wide);
    for (const std::string& camera : options.cameras) {
      std::vector<std::string> row = {table.scene_name, camera};
      for (const std::string& b : trees) {
        const Table1Row* r = table.find(camera, b);
        row.push_back(r ? format_number(r->combined.ops_per_ray) : "-");
      }
      std::vector<std::string> wide = row;
      std::string failing;
      for (const auto& [reading, tag] : readings) {
        const auto median = patent_relations(table, camera, reading, "median");
        const auto sah = patent_relations(table, camera, reading, "sah");
        // "yes", "no", "noise" (the seed intervals overlap) or "-" (a tree is missing).
        auto word = [](const std::vector<Table1Relation>& relations, const std::string& a, const std::string& b) {
          for (const Table1Relation& r : relations)
            if (r.a == a && r.b == b)
              return std::string(r.state == Table1Relation::State::Holds    ? "yes"
                                 : r.state == Table1Relation::State::Broken ? "no"
                                                                            : "noise");
          return std::string("-");
        };
        // Every tree below the median BVH: broken if one is, else unresolved if one is.
        bool any_no = false, any_missing = false, any_noise = false;
        for (const std::string& tree : {std::string("sbvh"), std::string("osah"), reading}) {
          const std::string w = word(median, tree, "median");
          any_no |= w == "no", any_missing |= w == "-", any_noise |= w == "noise";
        }
        const std::string all = any_no ? "no" : any_missing ? "-" : any_noise ? "noise" : "yes";
        const std::vector<std::pair<std::string, std::string>> cells = {
            {"all<median", all},
            {"AO<OSAH", word(median, reading, "osah")},
            {"AO<SBVH", word(median, reading, "sbvh")},
            {"AO<SAH", word(sah, reading, "sah")}};
        std::string fails;
        bool judged = false;  // a relation whose trees are all in the table
        for (const auto& [name, w] : cells) {
          wide.push_back(w);
          judged |= w != "-";
          if (w == "no" || w == "noise") fails += (fails.empty() ? "" : " ") + name + (w == "noise" ? "~" : "");
        }
        // Missing trees decide nothing: "-", not "holds".
        failing += (failing.empty() ? "" : " | ") + (!fails.empty() ? fails : judged ? std::string("holds") : "-");
      }
      row.push_back(failing);
      summary.add_row(o.wide ? wide : row);
      summary_wide.add_row(wide);
    }
  }
  const std::string cycle_runs = table1_cycle_runs_text(o.table);
  const std::string text = "Table 1 on every scene (TRV+IST ops/ray, sampled builders the mean over their seeds; "
                           "details in each scene's folder)\n" + cycle_runs + "\n\nThe patent's Table 1 (TRV+IST "
                           "ops/ray, reduction against BVH):\n" + patent_table1_text(false) + "\nOurs:\n" +
                           summary.plain();
  std::fputs(text.c_str(), stdout);
  write_file_atomic(o.table.out_dir / "summary.md",
                    "# Table 1 on every scene\n\n" + cycle_runs + "\n\n## The patent's Table 1\n\nTRV+IST "
                    "operations per ray (reduction against BVH), shown here once for every scene:\n\n" +
                        patent_table1_text(true) + "\n## Ours\n\nTRV+IST ops/ray; a sampled builder's figure is "
                        "the mean over its seeds, and a relation whose 95% seed intervals overlap is `noise`; each "
                        "scene's folder has the details.\n\n" + summary_wide.markdown());
  write_file_atomic(o.table.out_dir / "summary.csv", summary_wide.csv());
}

}  // namespace

void add_table1_command(CLI::App& root) {
  auto o = std::make_shared<Table1CommandOptions>();
  CLI::App* cmd = root.add_subcommand(
      "table1", "The patent's Table 1: ops/ray, fetches, DRAM bytes, cycles per builder and camera");
  cmd->footer("TRV+IST ops/ray, node fetches, DRAM bytes and cycles for median/SAH BVH, SBVH, OSAH and\n"
              "AO-BVH on a scene's two cameras, beside the patent's numbers.");
  cmd->add_option("--scene", o->table.scene, "Scene name or descriptor path")->capture_default_str();
  cmd->add_flag("--all-scenes", o->all_scenes,
                "Run on the default scene and every fetched real scene, with a summary table");
  // Lists take spaces or commas: --builders sah aobvh, or --builders sah,aobvh.
  cmd->add_option("--cameras", o->table.cameras, "Cameras (the patent's two viewpoints)")
      ->delimiter(',')->capture_default_str();
  cmd->add_option("--builders", o->table.builders, "Builders to compare (space- or comma-separated)")
      ->delimiter(',')->capture_default_str();
  cmd->add_option("--res", o->resolution, "Primary rays per camera, WxH")->capture_default_str();
  cmd->add_option("--ao", o->table.ao_samples, "AO rays per primary hit (-1: the scene's setting)")
      ->check(CLI::Range(-1, 1024))->capture_default_str();
  cmd->add_option("--diffuse-bounces", o->table.diffuse_bounces,
                  "Diffuse path bounces per primary hit (0..8; their rays count in the\ncombined figures and "
                  "have their own column)")
      ->check(CLI::Range(0u, kMaxDiffuseBounces))
      ->capture_default_str();
  cmd->add_flag("--opaque", o->table.opaque,
                "Alpha-tested materials as opaque (the same geometry without\nthe any-hit stage; trees "
                "built for it)");
  cmd->add_flag("--instanced", o->table.instanced,
                std::string(kInstancedHelp) + "\n(builders that build no BLAS, rdh and rdh-sbvh, are left out)");
  cmd->add_option("--seed", o->table.seed, "Seed of every random choice (rays and builders)")
      ->capture_default_str();
  cmd->add_option("--config", o->table.hardware, "Hardware preset or TOML for the cycle-level runs")
      ->capture_default_str();
  cmd->add_option("--frames", o->table.frames,
                  "Cycle-level frames of the same rays (the first cold; figures of the last)")
      ->check(CLI::Range(1u, 16u))->capture_default_str();
  cmd->add_option("--build-seeds", o->table.build_seeds,
                  "Trees per sampled builder (those reading the seed: osah, aobvh, aosbvh, rdh, rdh-sbvh):\n"
                  "seeds --build-seed, +1, ...; "
                  "their figures are the means with a 95% interval\n(cycles: the first seed's tree)")
      ->check(CLI::Range(1u, 64u))->capture_default_str();
  cmd->add_flag("--no-cycle", o->no_cycle, "Skip the cycle-level runs (no DRAM bytes or cycles)");
  cmd->add_option("-j,--jobs", o->table.jobs, "Cycle-level runs in parallel")
      ->check(CLI::Range(1u, 256u))->capture_default_str();
  cmd->add_option("--out-dir", o->table.out_dir, "Where table1.{md,csv,json} and the pictures go")
      ->capture_default_str();
  cmd->add_option("--node-formats,--node-format", o->node_formats,
                  "Node record formats: " + node_format_names("|") +
                      "\n(several: one Table 1 each in OUT_DIR/FORMAT, and a comparison)")
      ->delimiter(',')->capture_default_str();
  add_build_options(cmd, o->table.build);
  cmd->add_flag("--json", o->json, "Print table1.json to stdout instead of the text table");
  cmd->add_flag("--wide", o->wide, "Every column in the text tables (wider than 120 columns)");
  cmd->callback([o, cmd] {
    parse_resolution(o->resolution, o->table.width, o->table.height);
    finish_build_options(o->table.build);
    check_build_flags(o->table.build);
    // --seed is the seed of every random choice, the builders' included, unless
    // --build-seed gives theirs (as in build, trace and simulate).
    if (cmd->count("--build-seed") == 0) o->table.build.seed = o->table.seed;
    o->table.cycle_level = !o->no_cycle;
    o->table.rtsim_binary = self_executable();
    for (const std::string& f : o->node_formats) node_format_flag(f, "", "--node-formats");
    if (o->node_formats.empty()) throw InputError("--node-formats", "needs at least one format");
    OutputFolder out_dir;
    out_dir.prepare(o->table.out_dir, "--out-dir");
    if (o->node_formats.size() > 1) {
      if (o->all_scenes) throw InputError("--node-formats", "takes one scene (not --all-scenes)");
      // One Table 1 per format in its own folder, then the formats side by side.
      std::vector<Table1> tables;
      for (const std::string& f : o->node_formats) {
        Table1Options options = o->table;
        options.node_format = f;
        options.out_dir = o->table.out_dir / f;
        options.patent_table_page = "../formats.md";  // once, beside the formats
        tables.push_back(run_one(options, false, o->wide));
      }
      const std::string text = write_table1_formats(tables, o->table.out_dir);
      out_dir.keep();
      if (o->json) {
        nlohmann::json j = nlohmann::json::array();
        for (const std::string& f : o->node_formats) {
          std::ifstream in(o->table.out_dir / f / "table1.json");
          j.push_back(nlohmann::json::parse(in));
        }
        std::cout << j.dump(2) << "\n";
      } else {
        std::fputs(text.c_str(), stdout);
      }
      std::fprintf(stderr, "wrote %s/formats.{md,csv}, table1_formats.png\n",
                   o->table.out_dir.string().c_str());
      return;
    }
    o->table.node_format = o->node_formats.front();
    if (o->all_scenes) {
      run_all_scenes(*o);
      out_dir.keep();
      return;
    }
    run_one(o->table, !o->json, o->wide);
    out_dir.keep();
    if (o->json) {
      std::ifstream in(o->table.out_dir / "table1.json");
      std::fputs(std::string(std::istreambuf_iterator<char>(in), {}).c_str(), stdout);
    }
  });
}

}  // namespace rtsim::cli
