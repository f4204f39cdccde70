// docs/stats.md is what `rtsim stats-reference` makes from the model's own
// descriptions (reports/stats_reference.h): a stat added, renamed or described anew
// shows here first. RTSIM_WRITE_DOCS=1 writes the page again after such a change.
#include "cli_runner.h"
#include "stats_support.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace {
std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

TEST(StatsReference, TheDocIsWhatTheModelSays) {
  const auto dir = scratch_folder("stats_reference", "doc");
  const auto made = dir / "stats.md";
  const CliResult r = run_rtsim("stats-reference --out " + made.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::filesystem::path doc = std::filesystem::path(RTSIM_SOURCE_DIR) / "docs" / "stats.md";
  if (std::getenv("RTSIM_WRITE_DOCS")) std::filesystem::copy_file(made, doc, std::filesystem::copy_options::overwrite_existing);
  const std::string text = read_all(made);
  EXPECT_EQ(read_all(doc), text) << "docs/stats.md is stale: rerun with RTSIM_WRITE_DOCS=1 (or rtsim stats-reference "
                                    "--out docs/stats.md)";
  // Every stat of a run is in it, by its folded name.
  for (const char* name : {"`time.cycles`", "`core<c>.trv<u>.waiting_dram_cycles`", "`dram.bytes_by_type.<type>.<kind>`",
                           "`l2.slice<s>.amat`", "`frames.frame<k>.dram_bytes`", "`machine.trv.busy_cycles.mean`"})
    EXPECT_NE(text.find(name), std::string::npos) << name;
  std::filesystem::remove_all(dir);
}
