#pragma once
// rtsim claim: where the patent's claim holds. A campaign (resumable, and the same
// file `rtsim campaign emit --slurm` takes) over scenes x cameras x builders x
// seeds, in a star design: every factor (leaf size, T2/T1, node format, AO ray
// length, diffuse bounces, alpha testing, instancing) is varied alone around the defaults, so the map costs the sum of the
// factors' levels, not their product. Per patent relation (AO-BVH < SAH, < SBVH,
// < OSAH, every tree < median) and per condition, metric (TRV+IST ops, node
// fetches, DRAM bytes, per ray) and ray mix (primary, AO, diffuse, all rays): the mean
// relative difference over the seed replicates with a 95% t interval; the relation
// "holds" only where the interval lies below zero, "reverses" where it lies above.
// Also the rank correlation of each tree's modelled cost (SAH, weighted, EPO) with
// the measured ops/ray, and at the defaults the spatial reading of the AO-BVH
// (aosbvh) and our builders (rdh, rdh-sbvh).
#include <rtsim/reports/interval.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace rtsim {

// One factor of the star design: its levels and its default (the centre).
struct ClaimFactor {
  std::string name;                 // leaf | t2 | format | cutoff | diffuse | alpha | instanced
  std::vector<std::string> levels;  // value texts, the default among them
  std::string centre;
};

struct ClaimOptions {
  std::vector<std::string> scenes;  // empty: the built-in scenes and every fetched one
  std::vector<std::string> cameras = {"view1", "view2"};
  // The patent's four trees and the median BVH, in every condition.
  std::vector<std::string> builders = {"median", "sah", "sbvh", "osah", "aobvh"};
  // At the centre of the design only: the patent's AO-BVH read with spatial splits
  // (aosbvh, an SBVH-class build: in every condition it would cost the map a fifth
  // more), and ours (their comparison needs no factor map).
  std::vector<std::string> extra_builders = {"aosbvh", "rdh", "rdh-sbvh"};
  std::vector<ClaimFactor> factors = {
      {"leaf", {"1", "2", "4", "8"}, "4"},
      {"t2", {"0.25", "1", "4"}, "1"},  // T1 = 1: the ratio T2/T1
      {"format", {"bvh2-64", "bvh4-128", "bvh8-80q"}, "bvh2-64"},
      {"cutoff", {"0.02", "0.05", "0.2"}, "0.05"},  // AO ray length x scene diagonal
      {"diffuse", {"0", "1", "3"}, "0"},  // diffuse path bounces per primary hit (a ray mix of its own)
      // Alpha-tested materials tested (on) or opaque (off, simulate --opaque): only the
      // scenes that have alpha-tested materials run the off level.
      {"alpha", {"on", "off"}, "on"},
      // The scene flat (off) or with its instances, as a two-level tree (on,
      // simulate --instanced): only the scenes that have instances run the on level.
      {"instanced", {"off", "on"}, "off"},
  };
  uint32_t replicates = 5;  // seeds 1..N: each replicate's workload and builder seed
  std::string resolution = "64x64";
  int ao_rays = 4;          // AO rays per primary hit
  uint32_t frames = 2;      // the steady state: figures of the second, warm frame
  std::string preset = "mobile";
  int jobs = 2;             // simulations at once
  bool quick = false;       // recorded; quick_claim_options sets the sizes
  bool retry_failed = false;  // rerun jobs recorded as failed (campaign run --retry-failed)
  bool progress = false;
  std::filesystem::path out_dir = "claim";
  std::filesystem::path rtsim_binary;  // runs every job
  std::filesystem::path tree_cache;    // shared trees and their cost reports
};

// A smoke run of a minute or two: cornell, 3 replicates, one off-centre level per
// factor, 32x32.
ClaimOptions quick_claim_options(ClaimOptions base);

// The campaign document (JSON, docs/campaigns.md) the options describe.
std::string claim_campaign_json(const ClaimOptions& options);

struct ClaimSummary {
  size_t jobs = 0, ran = 0, failed = 0;
  size_t cells = 0, holds = 0, reverses = 0;
  double wall_seconds = 0;
  bool interrupted = false;  // stopped by a signal: nothing written, run again to resume
  std::string text;  // what the terminal shows
};

// Writes OUT/claim-campaign.json, runs the missing jobs (OUT/campaign/...), then
// OUT/claim.{md,json,csv} and the heatmaps claim_<relation>.png.
ClaimSummary run_claim(const ClaimOptions& options);

// Spearman's rank correlation (average ranks for ties); NaN if fewer than 3 points
// or a constant series.
double spearman(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace rtsim
