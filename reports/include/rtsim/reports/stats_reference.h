#pragma once
// docs/stats.md: every statistic rtsim writes, from the descriptions and units the
// model gives them (stats.h: each value carries both), one row per name with the
// instance numbers and the ray types and byte kinds folded into placeholders
// (core<c>.trv<u>.busy_cycles, dram.bytes_by_type.<type>.<kind>), the levels that
// write it, and the accounting identities the numbers obey.
//   rtsim stats-reference --out docs/stats.md   (a test keeps the file equal)
#include <nlohmann/json.hpp>

#include <filesystem>

#include <string>
#include <utility>
#include <vector>

namespace rtsim {

// One row of the reference.
struct StatReferenceRow {
  std::string pattern, unit, description;
  std::vector<std::string> levels;  // fidelity levels that write it
};

// The rows from stats.json documents of runs at the given levels. Throws
// std::runtime_error when one name carries two units or descriptions (a stat with
// two meanings), naming both.
std::vector<StatReferenceRow> stats_reference(const std::vector<std::pair<std::string, nlohmann::json>>& runs);
std::string stats_reference_markdown(const std::vector<StatReferenceRow>& rows, const std::string& how_made);

// Makes the reference: runs `rtsim simulate` (`binary`) at every level on a machine with
// every kind of instance (two cores, L2 slices, shading, two frames) in `work_dir`.
std::string make_stats_reference(const std::filesystem::path& binary, const std::filesystem::path& work_dir);

}  // namespace rtsim
