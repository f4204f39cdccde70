#pragma once
// The builder's knobs as command-line options, shared by every subcommand that
// builds trees (build, table1) so that a figure can be reproduced with the same flags.
#include <rtsim/builder/build.h>

#include <CLI/CLI.hpp>

namespace rtsim::cli {

// Adds --t1 ... --ao-normalise to `cmd`, writing into `params`. --osah-resolution
// sets both osah_width and osah_height (call finish_build_options after parsing).
void add_build_options(CLI::App* cmd, BuildParams& params);
inline void finish_build_options(BuildParams& params) { params.osah_height = params.osah_width; }

}  // namespace rtsim::cli
