// rtsim claim: where the patent's claim holds, with error bars (reports/claim.h).
#include "cli_util.h"
#include "commands.h"

#include <rtsim/reports/child_process.h>
#include <rtsim/reports/claim.h>

#include <rtsim/workloads/error.h>
#include <rtsim/workloads/files.h>
#include <rtsim/workloads/progress.h>
#include <rtsim/workloads/scene_registry.h>

#include <cstdio>
#include <filesystem>

namespace rtsim::cli {

namespace {
struct ClaimCommandOptions {
  ClaimOptions claim;
  bool quick = false, json = false, no_tree_cache = false;
  std::string tree_cache, binary;
};
}  // namespace

void add_claim_command(CLI::App& root) {
  auto o = std::make_shared<ClaimCommandOptions>();
  CLI::App* cmd = root.add_subcommand(
      "claim", "Where the patent's claim holds: its relations over a map of conditions, with 95% intervals");
  cmd->footer(
      "Runs a campaign (OUT/claim-campaign.json; resumable, and `rtsim campaign emit --slurm` takes the\n"
      "same file): scenes x cameras x builders x seeds, each factor (leaf size, T2/T1, node format, AO\n"
      "length, diffuse bounces, alpha testing) varied alone around the defaults; diffuse rays are a ray mix of their\n"
      "own. Writes claim.{md,json,csv} and a heatmap per relation.\n"
      "docs/claim.md explains the design and the verdicts.");
  cmd->add_option("--scenes", o->claim.scenes,
                  "scenes (default: the built-in ones and every fetched scene in the cache)");
  cmd->add_option("--cameras", o->claim.cameras, "cameras")->capture_default_str();
  CLI::Option* replicates =
      cmd->add_option("--replicates", o->claim.replicates, "seed replicates (>= 2)")->capture_default_str();
  CLI::Option* resolution = cmd->add_option("--res", o->claim.resolution, "image size WxH")->capture_default_str();
  cmd->add_option("--ao", o->claim.ao_rays, "AO rays per primary hit")->capture_default_str();
  cmd->add_option("--config", o->claim.preset, "hardware preset or TOML")->capture_default_str();
  cmd->add_option("-j,--jobs", o->claim.jobs, "simulations at once")->check(CLI::Range(1, 1024))->capture_default_str();
  cmd->add_option("--out-dir", o->claim.out_dir, "where the campaign, the report and the pictures go")
      ->capture_default_str();
  cmd->add_option("--tree-cache", o->tree_cache, "shared trees and their cost reports (default: $RTSIM_CACHE/trees)");
  cmd->add_flag("--no-tree-cache", o->no_tree_cache, "every job builds its own tree (no cost-model correlations)");
  cmd->add_option("--rtsim", o->binary,
                  "the rtsim that runs the jobs (default: this one; its revision is part of every key,\n"
                  "so a newer report can read an older binary's finished map)");
  cmd->add_flag("--quick", o->quick, "a smoke run of a minute or two (cornell, 3 replicates, 32x32)");
  cmd->add_flag("--json", o->json, "print claim.json to stdout instead of the summary");
  cmd->add_flag("--retry-failed", o->claim.retry_failed,
                "rerun the jobs recorded as failed (a read-only tree cache, a full disk)\ninstead of keeping them");
  cmd->callback([o, replicates, resolution] {
    // The flags as given first, then what --quick would replace: it must not hide them.
    uint32_t w = 0, h = 0;
    parse_resolution(o->claim.resolution, w, h);
    if (o->claim.replicates < 2) throw InputError("--replicates", "needs at least 2 for an interval");
    for (const CLI::Option* fixed : {replicates, resolution})
      if (o->quick && fixed->count() > 0)
        throw InputError(fixed->get_name(), "--quick sets it (3 replicates, 32x32); give one or the other");
    ClaimOptions options = o->quick ? quick_claim_options(o->claim) : o->claim;
    parse_resolution(options.resolution, w, h);
    options.rtsim_binary = o->binary.empty() ? self_executable() : std::filesystem::absolute(o->binary);
    // Another binary's trees are shared only where asked (as campaign run does).
    if (!o->binary.empty() && o->tree_cache.empty() && !o->no_tree_cache)
      throw InputError("--rtsim", "give --tree-cache (or --no-tree-cache) with another job binary");
    options.progress = Progress::enabled();
    options.tree_cache = usable_tree_cache(o->no_tree_cache       ? std::filesystem::path()
                                           : o->tree_cache.empty() ? scene_cache_dir() / "trees"
                                                                   : std::filesystem::absolute(o->tree_cache),
                                           "--tree-cache");
    check_output_folder(options.out_dir, "--out-dir");
    const ClaimSummary s = run_claim(options);
    if (s.interrupted) throw ExitStatus(130, "interrupted; the same command resumes");
    if (o->json)
      std::fputs(read_input_file(options.out_dir / "claim.json", kMaxDataFileBytes).c_str(), stdout);
    else
      std::fputs(s.text.c_str(), stdout);
    std::fflush(stdout);
    std::fprintf(stderr, "wrote %s/claim.{md,json,csv} and claim_<relation>.png in %.0f s\n",
                 options.out_dir.string().c_str(), s.wall_seconds);
    if (s.failed > 0) throw ExitStatus(1, std::to_string(s.failed) + " jobs failed (rtsim campaign status " +
                                              (options.out_dir / "claim-campaign.json").string() + ")");
  });
}

}  // namespace rtsim::cli
