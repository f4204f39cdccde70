#pragma once
// Table 1 of the patent, reproduced on a scene's two cameras: TRV+IST operations
// per ray and node fetches per ray for the BVH baselines (median and SAH, the two
// readings of the patent's plain "BVH"), SBVH, OSAH (per camera) and AO-BVH, with
// DRAM bytes per ray and cycles from the cycle-level model.
#include <rtsim/builder/build.h>
#include <rtsim/model/core/ray.h>
#include <rtsim/reports/interval.h>

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace rtsim {

struct Table1Options {
  std::string scene = "interior";
  std::vector<std::string> cameras = {"view1", "view2"};
  // The patent's four, its BVH and its AO-BVH each in both readings (median and SAH;
  // object and spatial splits), and ours, rdh, marked as ours.
  std::vector<std::string> builders = {"median", "sah", "sbvh", "osah", "aobvh", "aosbvh", "rdh"};
  // The builders that cast random rays (they read the builder seed: osah's AO rays,
  // aobvh's, rdh's samples) are built with this many seeds, build.seed, build.seed +
  // 1, ...: their counts are the means over those trees, with a 95% interval. The
  // cycle-level run and the heatmaps use the first seed's tree.
  uint32_t build_seeds = 5;
  uint32_t width = 256, height = 256;
  int ao_samples = -1;            // < 0: the scene's AO settings
  // Diffuse path bounces per primary hit (0: none, the patent's workload): their rays
  // count in the combined figures and have their own column, all depths together.
  uint32_t diffuse_bounces = 0;
  // Alpha-tested materials as opaque (--opaque): the same geometry without the
  // any-hit stage, trees built for it.
  bool opaque = false;
  // The scene with its instances (--instanced): two-level trees, a BLAS per mesh by
  // each builder (builders that build no BLAS are left out, said so) and a TLAS by SAH
  // (AO-BVH's occlusion-weighted, two_level.cpp).
  bool instanced = false;
  uint64_t seed = 1;
  std::string hardware = "mobile";  // preset or TOML for the cycle-level runs
  bool cycle_level = true;        // run the cycle-level model for DRAM bytes and cycles
  uint32_t jobs = 2;              // cycle-level runs in parallel (one process each)
  // Cycle-level frames: the first runs with cold caches, the figures are the last's
  // (the steady state); the cold frame's DRAM bytes are shown beside them.
  uint32_t frames = 2;
  std::filesystem::path out_dir = "table1";
  std::filesystem::path rtsim_binary;  // for the cycle-level child processes
  BuildParams build;              // one parameter set for every builder and scene
  // Node record format the trees are built (collapsed) for and traced with.
  std::string node_format = "bvh2-64";
  // Where the patent's Table 1 is shown: empty, on this table's own page; else the
  // page (relative to out_dir) that shows it once for several tables (--node-formats,
  // --all-scenes), which this page points to instead of repeating it.
  std::string patent_table_page;
};

// Per ray type (primary, AO, the diffuse depths together) and combined.
struct Table1Counts {
  uint64_t rays = 0;
  double ops_per_ray = 0, trv_per_ray = 0, ist_per_ray = 0, node_fetches_per_ray = 0;
  double box_tests_per_ray = 0;  // compares widths fairly: a wide node visit tests more boxes
  double tlas_trv_per_ray = 0, xfm_per_ray = 0;  // two-level trees: TLAS node visits (in TRV), transforms
  double dram_bytes_per_ray = -1;  // < 0: not measured (no cycle-level run)
  double pj_per_ray = -1;          // dynamic energy (model/sim/energy.h), cycle level
};

struct Table1Row {
  std::string camera, builder;
  // Counts per ray (means over the seeds for a sampled builder), and their spread.
  Table1Counts combined;
  Table1Counts primary, ao, diffuse;
  uint32_t seeds = 1;                   // trees the counts are the mean of
  Interval ops_combined, ops_primary, ops_ao, ops_diffuse;  // ops/ray over the seeds (n = seeds)
  uint64_t first_trv_ops = 0, first_ist_ops = 0;  // the first seed's tree: what the cycle level runs
  double cycles = -1;                  // the last (steady-state) frame
  double rays_per_joule = -1;          // cycle level, dynamic energy
  double cold_dram_bytes_per_ray = -1;  // the first frame, cold caches (frames > 1)
  double l1_node_hit_rate = -1, l2_hit_rate = -1;
  double build_seconds = 0, estimate_seconds = 0;
  double sah_cost = 0;
  uint64_t nodes = 0;                // of the tree
  double node_bytes_per_triangle = 0;  // node records in the format, / scene triangles
  bool counts_match_cycle_level = true;  // the invariant: same counts at every level
};

struct Table1 {
  Table1Options options;
  std::string scene_name;
  uint64_t triangles = 0;  // instanced: unique (each mesh's once)
  uint64_t instances = 0, placed_triangles = 0;  // instanced scenes
  float ao_length = 0;
  uint32_t ao_samples = 0;
  std::vector<Table1Row> rows;
  std::vector<std::string> verdicts;  // plain sentences: where the patent's ordering holds
  std::string counting_rule;
  const Table1Row* find(const std::string& camera, const std::string& builder) const;
};

// One relation of the patent's ordering, a < b in ops/ray: held or broken where the
// two rows' 95% seed intervals (a point for an unsampled builder) do not overlap,
// unresolved where they do.
struct Table1Relation {
  std::string a, b;
  enum class State { Holds, Broken, Unresolved } state = State::Holds;
};
// The ordering for one reading of the AO-BVH (aobvh: object splits, aosbvh: spatial)
// against one reading of its BVH (median or sah) on a camera: AO-BVH < OSAH, AO-BVH <
// SBVH, then SBVH, OSAH and AO-BVH < the BVH. Empty if a row is missing.
std::vector<Table1Relation> patent_relations(const Table1& table, const std::string& camera,
                                             const std::string& reading, const std::string& baseline);

// Builds the trees, traces the frames and (optionally) runs the cycle-level model.
// Writes the per-pixel ops of every (camera, builder) under out_dir/data for the plots.
Table1 run_table1(const Table1Options& options);

// table1.md, table1.csv, table1.json, and the pictures (bar chart of reductions,
// heatmaps side by side on one colour scale) via reports/scripts/table1_plots.py.
void write_table1(const Table1& table);

// Several node formats side by side (table1 --node-formats): ops/ray, box tests,
// fetches, node bytes and the reductions per builder and format, written to
// out_dir/formats.{md,csv} with a chart of reductions by format
// (table1_formats.png); returns the text for the terminal.
std::string write_table1_formats(const std::vector<Table1>& tables,
                                 const std::filesystem::path& out_dir);

// The patent's Table 1 (TRV+IST ops/ray, reduction against its BVH), as Markdown or text.
std::string patent_table1_text(bool markdown);

// Which hardware the cycle-level runs used, in one sentence ("Cycle-level runs:
// hardware preset 'mobile' (--config), 2 frames ..."), or that there were none.
std::string table1_cycle_runs_text(const Table1Options& options);

// The figures a table's page shows (table1.json "figures"; the plot script draws
// exactly these): the reductions only where some builder is compared with a
// baseline (median or SAH) other than itself, the heatmaps always.
std::vector<std::string> table1_figures(const Table1& table);

// What the terminal shows: within 120 columns, or every column with `wide`.
std::string table1_text(const Table1& table, bool wide = false);

// The patent's Table 1 (ops/ray), for printing beside ours.
struct PatentTable1Entry {
  const char* builder;
  double viewpoint1, viewpoint2;
};
const std::array<PatentTable1Entry, 4>& patent_table1();

}  // namespace rtsim
