#pragma once
// Reports run `rtsim` subcommands as child processes (SystemC elaborates once per
// process) and read back their JSON results. The pieces every such report shares.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <initializer_list>
#include <string>

namespace rtsim {

// The running executable (/proc/self/exe): the rtsim a report runs as its child.
std::filesystem::path self_executable();

// One shell word, single-quoted, safe for any path or name.
std::string shell_quote(const std::string& word);

// The value of a stats.json / host.json leaf ({"value", "unit", "description"}) at
// `path`; -1 when the path is absent.
double stat_value(const nlohmann::json& stats, std::initializer_list<const char*> path);

}  // namespace rtsim
