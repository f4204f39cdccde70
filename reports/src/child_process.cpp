#include <rtsim/reports/child_process.h>

namespace rtsim {

std::filesystem::path self_executable() { return std::filesystem::read_symlink("/proc/self/exe"); }

std::string shell_quote(const std::string& word) {
  std::string out = "'";
  for (char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

double stat_value(const nlohmann::json& stats, std::initializer_list<const char*> path) {
  const nlohmann::json* node = &stats;
  for (const char* key : path) {
    if (!node->is_object() || !node->contains(key)) return -1;
    node = &(*node)[key];
  }
  return node->is_object() && node->contains("value") ? (*node)["value"].get<double>() : -1;
}

}  // namespace rtsim
