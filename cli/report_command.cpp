// rtsim report DB: Markdown + HTML report with figures of a campaign's results.
#include "commands.h"

#include <rtsim/reports/campaign_report.h>

#include <cstdio>
#include <memory>

namespace rtsim::cli {

void add_report_command(CLI::App& root) {
  auto o = std::make_shared<CampaignReportOptions>();
  auto database = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>("report");
  auto no_figures = std::make_shared<bool>(false);
  CLI::App* cmd = root.add_subcommand(
      "report", "Markdown + HTML report (memory traffic, hit rates, cycles, ops) of a campaign "
                "results database");
  cmd->add_option("database", *database, "results database (rtsim-campaigns/<name>/results.sqlite)")
      ->required();
  cmd->add_option("-o,--out", *out, "output folder")->capture_default_str();
  cmd->add_option("--campaign", o->campaign, "only this campaign (default: every one in the file)");
  cmd->add_flag("--no-figures", *no_figures, "tables only (no python3-matplotlib needed)");
  cmd->callback([=] {
    o->database = *database;
    o->out_dir = *out;
    o->figures = !*no_figures;
    const CampaignReportFiles files = write_campaign_report(*o);
    std::printf("%s\n%s\n%zu figures in %s\n", files.markdown.string().c_str(),
                files.html.string().c_str(), files.figures.size(), o->out_dir.string().c_str());
  });
}

}  // namespace rtsim::cli
