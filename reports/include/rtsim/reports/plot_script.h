#pragma once
// Pictures are drawn by Python scripts under reports/scripts with Debian's
// python3-matplotlib. This finds the interpreter and the scripts and runs one.
#include <filesystem>
#include <string>
#include <vector>

namespace rtsim {

// $RTSIM_SCRIPTS_DIR, else the source tree's reports/scripts (fixed at build time).
std::filesystem::path plot_scripts_dir();

// Debian's /usr/bin/python3 (which python3-matplotlib serves) unless $RTSIM_PYTHON
// names another; a python3 earlier on PATH may lack matplotlib.
std::string plot_python();

// Runs `python3 <scripts>/<script> args...`; throws std::runtime_error naming the
// command when it fails (the tables written before stay valid).
void run_plot_script(const std::string& script, const std::vector<std::string>& args);

}  // namespace rtsim
