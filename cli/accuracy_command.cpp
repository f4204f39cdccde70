// rtsim accuracy: what accuracy costs in time (fidelity levels, builder knobs, AO
// rays per pixel, resolution), with the settings it recommends from the numbers.
#include "cli_util.h"
#include "commands.h"

#include <rtsim/reports/accuracy.h>
#include <rtsim/reports/child_process.h>

#include <rtsim/workloads/files.h>

#include <cstdio>
#include <filesystem>

namespace rtsim::cli {

namespace {
struct AccuracyCommandOptions {
  AccuracyOptions accuracy;
  bool quick = false, json = false;
};
}  // namespace

void add_accuracy_command(CLI::App& root) {
  auto o = std::make_shared<AccuracyCommandOptions>();
  CLI::App* cmd = root.add_subcommand(
      "accuracy", "What accuracy costs in time, and the settings the numbers recommend");
  cmd->footer("Fidelity levels, AO-BVH rays per primitive, binned vs full-sweep SAH, SBVH alpha, AO rays\n"
              "per pixel, resolution, and memory traffic against resolution and frames, each against its\n"
              "error; writes accuracy.{md,json,csv}, accuracy_tradeoffs.png and accuracy_traffic.png.");
  cmd->add_option("--scene", o->accuracy.scene, "Scene name or descriptor path")->capture_default_str();
  cmd->add_option("--camera", o->accuracy.camera, "Camera")->capture_default_str();
  cmd->add_option("--out-dir", o->accuracy.out_dir, "Where the report and the picture go")->capture_default_str();
  cmd->add_option("--config", o->accuracy.hardware, "Hardware preset or TOML for the simulate runs")
      ->capture_default_str();
  cmd->add_option("--seed", o->accuracy.seed, "Seed of every random choice")->capture_default_str();
  cmd->add_option("--fidelity-scenes", o->accuracy.fidelity_scenes,
                  "Scenes the fidelity levels are compared on (default: --scene and,\nunless --quick, the fetched "
                  "memory-bound dragon and black_forest)");
  cmd->add_option("--traffic-scenes", o->accuracy.traffic_scenes,
                  "Scenes of the memory-traffic section (default: --scene),\ne.g. dragon-small interior "
                  "black_forest");
  cmd->add_option("--traffic-res", o->accuracy.traffic_resolutions,
                  "Square resolutions of the memory-traffic section")
      ->capture_default_str();
  cmd->add_option("--traffic-frames", o->accuracy.traffic_frames,
                  "Frames per memory-traffic run (the first is cold)")
      ->capture_default_str();
  cmd->add_flag("--quick", o->quick, "Small sizes: a smoke run of well under a minute on small scenes");
  cmd->add_flag("--json", o->json, "Print accuracy.json to stdout instead of the text report");
  cmd->callback([o] {
    AccuracyOptions options = o->quick ? quick_accuracy_options(o->accuracy) : o->accuracy;
    options.rtsim_binary = self_executable();
    OutputFolder out_dir;
    out_dir.prepare(options.out_dir, "--out-dir");
    const AccuracyReport report = run_accuracy(options);
    write_accuracy(report);
    out_dir.keep();
    if (o->json)
      std::fputs(read_input_file(options.out_dir / "accuracy.json", kMaxConfigFileBytes).c_str(), stdout);
    else
      std::fputs(accuracy_text(report).c_str(), stdout);
    std::fflush(stdout);  // before the stderr line, so a shared log reads in order
    std::fprintf(stderr, "wrote %s/accuracy.{md,json,csv}, accuracy_tradeoffs.png, accuracy_ao_images.png and accuracy_traffic.png\n",
                 options.out_dir.string().c_str());
  });
}

}  // namespace rtsim::cli
