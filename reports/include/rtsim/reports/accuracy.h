#pragma once
// What accuracy costs in time: a built-in campaign over the knobs that trade
// accuracy for host time, and the settings it recommends from what it measured.
//  1. fidelity levels (functional, lt, cycle): host time and simulated rays per
//     host second against their error in cycles and DRAM bytes relative to cycle;
//  2. builder knobs: AO rays per primitive K for AO-BVH (against K = reference),
//     binned vs full-sweep SAH, SBVH alpha;
//  3. AO rays per pixel against the error of the AO image (to a high-count reference);
//  4. resolution (ray count) against the stability of ops/ray, over several seeds;
//  5. memory traffic (DRAM bytes per ray, cycles per ray) against resolution and
//     frames: the cold first frame against the warm steady state, on one or more scenes.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace rtsim {

struct AccuracyOptions {
  std::string scene = "interior";
  std::string camera = "view1";        // empty: the scene's first camera
  std::filesystem::path out_dir = "accuracy";
  std::filesystem::path rtsim_binary;  // for the lt / cycle child processes
  std::string hardware = "mobile";     // preset or TOML for the simulate runs
  uint64_t seed = 1;
  std::string builder = "aobvh";       // tree of sections 1, 3 and 4 (default parameters)
  bool quick = false;                  // recorded only; quick_accuracy_options sets the sizes

  // What "good enough" means for the recommendations (all stated in the report).
  double tolerance = 0.01;           // ops/ray within 1% of the most exact setting
  double fidelity_tolerance = 0.05;  // cycles / DRAM bytes within 5% of the cycle level
  double image_rmse_target = 0.05;   // AO image RMSE (AO in [0, 1]) at most 0.05

  // 1. fidelity levels: square resolutions, each level once per resolution and scene
  std::vector<uint32_t> fidelity_resolutions = {64, 128, 256};
  // The scenes the levels are compared on. Empty: the report's scene and, unless
  // quick, the memory-bound dragon and black_forest where they are fetched (a
  // compute-bound scene alone would recommend a level that fails on them).
  std::vector<std::string> fidelity_scenes;
  // 2. builder knobs, ops/ray traced at this square resolution
  uint32_t knob_resolution = 128;
  std::vector<uint32_t> ao_rays_per_primitive = {1, 4, 16, 64};
  uint32_t ao_rays_reference = 256;
  // ... and the triangles that share one estimate (at the default K; the reference
  // stays ao_rays_reference rays per triangle)
  std::vector<uint32_t> ao_shares = {1, 4, 16, 64};
  std::vector<uint32_t> sah_bins = {32, 0};  // 0 = full sweep
  std::vector<float> sbvh_alphas = {1e-3f, 1e-5f, 1e-7f};
  // 3. AO rays per pixel against a reference image
  uint32_t ao_image_resolution = 96;
  std::vector<uint32_t> ao_samples = {1, 4, 16, 64};
  uint32_t ao_samples_reference = 256;
  // 4. resolution against the stability of ops/ray
  std::vector<uint32_t> resolutions = {8, 16, 32, 64, 128, 256, 512};
  std::vector<uint64_t> seeds = {1, 2, 3};
  // 5. memory traffic against resolution and frames (functional level for DRAM
  // bytes, which it counts as the cycle level does within a few tenths of a percent;
  // the cycle level for cycles, up to traffic_cycle_resolution)
  std::vector<std::string> traffic_scenes;  // empty: the report's scene
  std::vector<uint32_t> traffic_resolutions = {64, 128, 256, 512};
  uint32_t traffic_frames = 3;              // per run: frame 1 cold, the last the steady state
  uint32_t traffic_cycle_resolution = 256;  // cycle-level runs up to this resolution
  double traffic_tolerance = 0.05;          // within 5% ...
  double traffic_floor_bytes = 0.5;         // ... or 0.5 DRAM bytes per ray, whichever is larger
};

// The sizes of a sub-minute smoke run (keeps scene, camera, out_dir, binary, seed).
AccuracyOptions quick_accuracy_options(AccuracyOptions base);

// 1. One fidelity level at one resolution (a child `rtsim simulate` process).
struct FidelityPoint {
  std::string scene;  // the scene's name
  std::string level;  // functional | lt | cycle
  uint32_t resolution = 0;
  uint64_t rays = 0;
  double host_seconds = 0;         // simulation wall time (host.json)
  double cpu_seconds = 0;          // simulation CPU time (host.json)
  double process_seconds = 0;      // the whole child process (loading the scene and tree too)
  double rays_per_host_second = 0;
  double rays_per_cpu_second = 0;  // fair on a loaded machine: the speed comparisons use it
  double cycles = 0, dram_bytes = 0, ops_per_ray = 0;
  double cycle_error = 0, dram_error = 0;  // signed, relative to the cycle level at this resolution
  bool counts_match_cycle = true;          // TRV / IST / ray counts identical to the cycle level
};

// 2. One builder setting.
struct KnobPoint {
  std::string family;  // ao_rays | sah_bins | sbvh_alpha
  std::string label;   // e.g. "K=16", "bins=32", "full sweep", "alpha=1e-05"
  double value = 0;    // K, bins or alpha
  bool reference = false;            // the most exact setting of its family
  double estimate_seconds = 0, build_seconds = 0;
  double total_seconds() const { return estimate_seconds + build_seconds; }
  double cpu_seconds = 0;            // process CPU time of estimate + build (all threads)
  double sah_cost = 0;
  uint64_t references = 0;
  double ops_per_ray = 0;
  double ops_error = 0;              // signed, relative to the family's reference
  double occlusion_rmse = -1;        // ao_rays: per-triangle occlusion values against K = reference
  double occlusion_max_error = -1;
  double weight_rmse = -1;           // ao_rays: the builder's weights against the reference weights
};

// 3. One AO sample count.
struct AoSamplesPoint {
  uint32_t samples = 0;
  bool reference = false;
  uint64_t rays = 0;
  double seconds = 0;      // run_frame wall time (primary + AO rays, functional core)
  double cpu_seconds = 0;  // run_frame process CPU time (all threads)
  double image_rmse = 0;   // against the reference image, over pixels whose primary ray hit
  double ops_per_ray = 0, ao_ops_per_ray = 0;
};

// 4. One (resolution, seed).
struct ResolutionPoint {
  uint32_t resolution = 0;
  uint64_t seed = 0;
  uint64_t rays = 0;
  double seconds = 0, cpu_seconds = 0;
  double ops_per_ray = 0;
  double error = 0;  // signed, relative to the mean over seeds at the highest resolution
};

// 5. One traffic run: a scene at one resolution and level, every frame's figures.
struct TrafficPoint {
  std::string scene, level;  // functional | cycle
  uint32_t resolution = 0;
  uint64_t rays = 0;                       // per frame
  std::vector<double> dram_bytes_per_ray;  // per frame: [0] cold caches, back() the steady state
  std::vector<double> cycles_per_ray;      // per frame (cycle level only)
  double cpu_seconds = 0;                  // simulation CPU time of all frames
};

// What the traffic runs of one scene say.
struct TrafficVerdict {
  std::string scene;
  uint32_t frames_needed = 0;      // frames whose last is within tolerance of the steady state
  bool frames_confirmed = false;   // frames_needed < traffic_frames (else only a lower bound)
  uint32_t resolution_needed = 0;  // steady-state DRAM B/ray within tolerance from here up; 0: none
  bool resolution_converged = false;  // the two highest resolutions agree within tolerance
  double cold_bytes_per_ray = 0, steady_bytes_per_ray = 0;  // at the highest resolution
  double cycles_per_ray = 0;       // steady state, highest cycle-level resolution
  std::string summary;             // a sentence for the report
};

struct Recommendation {
  std::string topic, setting, why;
};

struct AccuracyReport {
  AccuracyOptions options;
  std::string scene_name, camera;
  uint64_t triangles = 0;
  uint32_t scene_ao_samples = 0;  // AO rays per primary hit in sections 1, 2 and 4
  float ao_length = 0;
  std::vector<FidelityPoint> fidelity;
  std::vector<KnobPoint> knobs;
  std::vector<AoSamplesPoint> ao;
  std::vector<ResolutionPoint> resolution;
  double resolution_reference_ops = 0;     // mean ops/ray over seeds at the highest resolution
  uint32_t resolution_needed = 0;          // smallest resolution within tolerance from there up
  uint64_t rays_needed = 0;                // rays of one frame at that resolution
  std::vector<TrafficPoint> traffic;
  std::vector<TrafficVerdict> traffic_verdicts;
  std::vector<Recommendation> recommendations;
  double total_seconds = 0;
};

// Judges the traffic points of one scene (run_accuracy calls it; exposed for tests).
TrafficVerdict judge_traffic(const std::string& scene, const std::vector<TrafficPoint>& points,
                             const AccuracyOptions& options);

// Runs the five sections (the lt and cycle runs as child processes of options.rtsim_binary).
AccuracyReport run_accuracy(const AccuracyOptions& options);

// Derives the recommendations from the measured numbers (run_accuracy calls it).
std::vector<Recommendation> recommend(const AccuracyReport& report);

// accuracy.md, accuracy.json, accuracy.csv, accuracy_tradeoffs.png and accuracy_ao_images.png (via
// reports/scripts/accuracy_plots.py) in options.out_dir, each written atomically.
void write_accuracy(const AccuracyReport& report);

std::string accuracy_text(const AccuracyReport& report);  // what the terminal shows

}  // namespace rtsim
