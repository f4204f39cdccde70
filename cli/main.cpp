// rtsim: a hardware-model simulator of a ray-tracing accelerator.
#include "commands.h"

#include <rtsim/workloads/error.h>

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  CLI::App app{"rtsim: build BVHs (SAH, SBVH, OSAH, AO-BVH) and simulate a ray-tracing accelerator\n"
               "(TRV, IST, shading, caches, DRAM) at three fidelity levels"};
  rtsim::cli::add_rtsim_commands(app);
  // No arguments at all: the list of subcommands, as --help gives it, not an error.
  if (argc <= 1) {
    std::fputs(app.help().c_str(), stdout);
    return 0;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // CLI11 prints help/usage errors itself; bad command lines exit with 2.
    const int code = app.exit(e);
    return code == 0 ? 0 : rtsim::kExitBadInput;
  } catch (const rtsim::InputError& e) {
    std::fprintf(stderr, "rtsim: error: %s\n", e.what());
    return rtsim::kExitBadInput;
  } catch (const rtsim::cli::ExitStatus& e) {
    if (*e.what()) std::fprintf(stderr, "rtsim: %s\n", e.what());
    return e.code;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtsim: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
