#include <rtsim/reports/child_process.h>
#include <rtsim/reports/plot_script.h>

#include <cstdlib>
#include <stdexcept>

namespace rtsim {

std::filesystem::path plot_scripts_dir() {
  if (const char* dir = std::getenv("RTSIM_SCRIPTS_DIR"); dir && *dir) return dir;
  return RTSIM_SCRIPTS_DIR;
}

std::string plot_python() {
  if (const char* python = std::getenv("RTSIM_PYTHON"); python && *python) return python;
  return std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
}

void run_plot_script(const std::string& script, const std::vector<std::string>& args) {
  std::string command = shell_quote(plot_python()) + " " + shell_quote((plot_scripts_dir() / script).string());
  for (const std::string& a : args) command += " " + shell_quote(a);
  if (std::system(command.c_str()) != 0)
    throw std::runtime_error("drawing the pictures failed (" + command +
                             "); is python3-matplotlib installed? Tables written before stay valid.");
}

}  // namespace rtsim
