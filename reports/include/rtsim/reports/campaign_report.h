#pragma once
// `rtsim report DB`: a Markdown and an HTML report of a campaign's results store, with
// the memory-traffic figures (DRAM bytes/ray by ray type and data kind per builder and
// preset, L1/L2 hit rates, cycles, ops/ray, node fetches/ray, sweeps) drawn by
// reports/scripts/campaign_plots.py with python3-matplotlib, and the headline table.
#include <filesystem>
#include <string>
#include <vector>

namespace rtsim {

struct CampaignReportOptions {
  std::filesystem::path database;
  std::filesystem::path out_dir;
  std::string campaign;  // "" = every campaign in the database
  bool figures = true;   // false: tables only (no Python needed)
};

struct CampaignReportFiles {
  std::filesystem::path markdown, html, data;
  std::vector<std::filesystem::path> figures;
};

// Throws InputError if the database does not exist or holds no runs of the campaign;
// std::runtime_error if the plot script fails (the tables are written first).
CampaignReportFiles write_campaign_report(const CampaignReportOptions& options);

}  // namespace rtsim
