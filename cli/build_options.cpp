#include "build_options.h"

#include <map>
#include <string>

namespace rtsim::cli {

void add_build_options(CLI::App* cmd, BuildParams& p) {
  cmd->add_option("--t1", p.t1, "cost of one ray-node test")->capture_default_str();
  cmd->add_option("--t2", p.t2, "cost of one ray-triangle test")->capture_default_str();
  cmd->add_option("--max-leaf-size", p.max_leaf_size, "max triangles per leaf")->capture_default_str();
  cmd->add_option("--max-depth", p.max_depth, "max leaf depth (root = 0)")->capture_default_str();
  cmd->add_option("--bins", p.bins, "SAH bins (0 = full sweep)")->capture_default_str();
  cmd->add_option("--threads", p.threads, "threads (0 = all); never changes the tree")->capture_default_str();
  cmd->add_option("--sbvh-alpha", p.sbvh_alpha, "sbvh: overlap threshold x root area")->capture_default_str();
  cmd->add_option("--sbvh-budget", p.sbvh_reference_budget, "sbvh: references <= budget x N")->capture_default_str();
  cmd->add_option("--osah-w", p.osah_w, "osah: visibility weight in mixed nodes")->capture_default_str();
  cmd->add_option("--osah-resolution", p.osah_width, "osah: primary rays per side")->capture_default_str();
  cmd->add_option("--ao-rays", p.ao_rays, "aobvh: AO rays per triangle (K)")->capture_default_str();
  cmd->add_option("--ao-cutoff", p.ao_cutoff_relative,
                  "aobvh: AO ray length x scene diagonal (< 0: the scene's setting, default 0.05)")
      ->capture_default_str();
  cmd->add_option("--ao-floor", p.ao_weight_floor, "aobvh: weight floor, w = floor + (1-floor) x value")
      ->capture_default_str();
  cmd->add_flag("--ao-both-sides", p.ao_both_sides, "aobvh: cast AO rays from both triangle sides");
  cmd->add_option("--ao-normalise", p.ao_normalise,
                  "aobvh: on = weights scaled to mean 1 (equal values give the SAH tree); off = the\n"
                  "patent's literal sum of occlusion values in place of the count, same T2")
      ->transform(CLI::CheckedTransformer(std::map<std::string, bool>{{"on", true}, {"off", false}}))
      ->default_str("on");
  cmd->add_option("--rdh-resolution", p.rdh_resolution,
                  "rdh: sample primary rays per side per camera (0 = none: the SAH tree)")
      ->capture_default_str();
  cmd->add_option("--rdh-ao-rays", p.rdh_ao_rays, "rdh: sample AO rays per primary hit")
      ->capture_default_str();
  cmd->add_option("--rdh-prior", p.rdh_prior,
                  "rdh: k pseudo-rays spread by surface area, P_i = (A_i/A + n_i/k) / (1 + n/k)")
      ->capture_default_str();
  cmd->add_option("--rdh-cameras", p.rdh_cameras,
                  "rdh: camera = the run's camera only, all = every camera of the scene")
      ->check(CLI::IsMember({"camera", "all"}))
      ->capture_default_str();
  cmd->add_flag("--rdh-spatial-splits", p.rdh_spatial_splits,
               "rdh: also SBVH's spatial splits (--sbvh-alpha, --sbvh-budget), rays counted for them too");
  cmd->add_option("--build-seed", p.seed, "seed of the builders' random choices (AO rays; default: --seed)")
      ->capture_default_str();
}

}  // namespace rtsim::cli
