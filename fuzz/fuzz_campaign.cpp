// Campaign files (TOML or JSON): parsed, expanded into jobs, every job's
// simulate arguments formed.
#include "fuzz_support.h"

#include <rtsim/reports/campaign.h>
#include <rtsim/workloads/config_reader.h>

RTSIM_FUZZ_TARGET(campaign) {
  using namespace rtsim::fuzz;
  if (size == 0) return 0;
  const bool toml = data[0] & 1;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  const std::filesystem::path file = scratch_dir() / (toml ? "campaign.toml" : "campaign.json");
  expect_only_input_errors([&] {
    const nlohmann::json doc = rtsim::parse_config_text(text, file.string(), toml);
    const rtsim::Campaign campaign = rtsim::parse_campaign(doc, file, "fuzzrevision");
    size_t jobs = 0;
    for (const rtsim::CampaignJob& job : campaign.jobs) {
      (void)job.simulate_arguments(scratch_dir() / "out");
      if (++jobs == 64) break;
    }
  });
  return 0;
}
