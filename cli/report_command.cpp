// rtsim report DB: Markdown + HTML report with figures of a campaign's results.
// The database is opened read-only: a report never changes what it reads.
#include "cli_util.h"
#include "commands.h"

#include <rtsim/reports/campaign_report.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>
#include <memory>

namespace rtsim::cli {

void add_report_command(CLI::App& root) {
  auto o = std::make_shared<CampaignReportOptions>();
  auto database = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>("report");
  auto no_figures = std::make_shared<bool>(false);
  auto json = std::make_shared<bool>(false);
  CLI::App* cmd = root.add_subcommand(
      "report", "Markdown + HTML report of a campaign's results database (read-only)");
  cmd->add_option("database", *database, "results database (<campaign folder>/rtsim-campaigns/<name>/results.sqlite)")
      ->required();
  cmd->add_option("--out-dir", *out, "output folder")->capture_default_str();
  add_deprecated_option(cmd, "-o,--out", "--out-dir", *out);
  cmd->add_option("--campaign", o->campaign, "only this campaign (default: every one in the file)");
  cmd->add_flag("--no-figures", *no_figures, "tables only (no python3-matplotlib needed)");
  cmd->add_flag("--json", *json, "print the written files as JSON");
  cmd->callback([=] {
    o->database = *database;
    o->out_dir = *out;
    o->figures = !*no_figures;
    OutputFolder out_dir;
    out_dir.prepare(o->out_dir, "--out-dir");
    const CampaignReportFiles files = write_campaign_report(*o);
    out_dir.keep();
    if (*json) {
      nlohmann::json j = {{"markdown", files.markdown.string()},
                          {"html", files.html.string()},
                          {"data", files.data.string()},
                          {"figures", nlohmann::json::array()}};
      for (const auto& f : files.figures) j["figures"].push_back(f.string());
      std::cout << j.dump(2) << "\n";
      return;
    }
    std::printf("%s\n%s\n%zu figures in %s\n", files.markdown.string().c_str(),
                files.html.string().c_str(), files.figures.size(), o->out_dir.string().c_str());
  });
}

}  // namespace rtsim::cli
