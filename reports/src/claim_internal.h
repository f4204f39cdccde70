#pragma once
// What rtsim claim's analysis (claim.cpp) hands to its report (claim_output.cpp):
// the relations, the map's cells with their intervals, the cost-model correlations
// and the figures of every builder. Internal to the reports library.
#include <rtsim/reports/claim.h>
#include <rtsim/reports/interval.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace rtsim::claim_detail {

// The measured quantities and the ray mixes they are read for.
inline const char* const kMetrics[] = {"ops", "node_fetches", "dram_bytes"};
inline const char* const kMetricText[] = {"TRV+IST ops/ray", "node fetches/ray", "DRAM B/ray"};
// "diffuse": every diffuse bounce's rays together (ray types diffuse1, diffuse2, ...),
// only in the conditions that trace them.
inline const char* const kMixes[] = {"primary", "ao", "diffuse", "all"};
constexpr size_t kMetricCount = 3, kMixCount = 4;

// The tree-only conditions: the default for every tree but the camera-dependent
// (unseen) or ray-sampling (surfaces) ones, which are built from other rays.
struct TreeOnlyCondition {
  const char* level;   // the condition's "trees" value
  const char* name;    // as the report names it
  const char* suffix;  // after a builder's name in the table of absolute figures
};
inline const TreeOnlyCondition kTreeOnlyConditions[] = {
    {"unseen", "camera=unseen", ", built for another camera"},
    {"surfaces", "rdh-rays=surfaces", ", from surface AO rays"}};
inline const char* const kUnseenName = kTreeOnlyConditions[0].name;
inline const char* const kSurfacesName = kTreeOnlyConditions[1].name;
// AO sample points of the view-independent RDH: 128^2 (x 4 AO rays), as many rays as
// a 128x128 camera's (the modelled cost of fresh surface rays on interior: 30.0 at
// 48^2, 29.1 at 128^2, 28.7 at 256^2 for twice the build time).
constexpr uint32_t kSurfaceResolution = 128;

// A relation "a < b" (a's figure below b's); "all<median": every patent tree below
// the median BVH at once.
struct Relation {
  std::string name, a, b, text;
};

// One job's figures: [metric][mix]; NaN where the run did not report one.
struct Figures {
  double v[kMetricCount][kMixCount];
};

// One cell of the map: a relation in one (scene, camera, condition), metric, mix.
struct Cell {
  std::string relation, scene, camera, condition, metric, mix;
  Interval effect;  // % of b's figure (all<median: the least favourable of the four)
  std::string verdict;
};

// Spearman's rank correlation of a cost with measured ops/ray over a set of trees.
struct Correlation {
  std::string scene, camera, mix, trees;
  size_t points = 0;
  double sah = NAN, weighted = NAN, epo = NAN;
};

// (scene, camera, condition) -> builder -> replicate seed -> figures.
using FiguresByWhere =
    std::map<std::tuple<std::string, std::string, std::string>, std::map<std::string, std::map<uint64_t, Figures>>>;
// (scene, builder, condition) -> build seconds of the trees.
using BuildSeconds = std::map<std::tuple<std::string, std::string, std::string>, std::vector<double>>;

struct ClaimAnalysis {
  std::vector<Relation> relations;
  std::vector<std::string> conditions;  // names, in design order: the default first
  FiguresByWhere figures;
  BuildSeconds build_seconds;
  std::vector<Cell> cells;
  std::vector<Correlation> correlations;
  std::vector<std::string> sentences;
};

struct ClaimRun {
  size_t jobs = 0, ran = 0, failed = 0;
  double run_seconds = 0;
  std::string revision;
};

std::string interval_text(const Interval& i);  // "+1.2% [+0.8, +1.6]"
std::string picture_name(std::string relation);  // claim_aobvh-lt-sah.png
std::vector<std::string> claim_scenes(const ClaimOptions& o);
// The builders a tree-only condition ("unseen", "surfaces") rebuilds.
std::vector<std::string> condition_builders(const ClaimOptions& o, const std::string& trees);

// Writes OUT/claim.{json,csv,md} and draws the heatmaps; returns a line saying why the
// pictures were not drawn, or "".
std::string write_claim_report(const ClaimOptions& o, const ClaimAnalysis& analysis, const ClaimRun& run);

}  // namespace rtsim::claim_detail
