// The docs and the files they describe say the same: the numbers the docs give
// for the example campaigns (resolution, jobs, ranges) are those of the campaign
// files, and every `rtsim ... --flag` the docs and the README show is a flag of
// that subcommand under its current spelling (not a deprecated one).
#include "commands.h"

#include <rtsim/model/sim/config.h>
#include <rtsim/reports/campaign.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include <unistd.h>

namespace {

namespace fs = std::filesystem;
const fs::path kSource = RTSIM_SOURCE_DIR;

std::string read_all(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The text from a Markdown heading to the next heading of its level or above.
std::string section(const std::string& doc, const std::string& heading) {
  const size_t start = doc.find(heading);
  if (start == std::string::npos) return "";
  const size_t end = doc.find("\n## ", start + heading.size());
  return doc.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

std::vector<double> override_values(const rtsim::Campaign& c, const std::string& key) {
  std::vector<double> out;
  for (const rtsim::CampaignJob& j : c.jobs)
    if (j.overrides.count(key)) out.push_back(std::stod(j.overrides.at(key)));
  std::sort(out.begin(), out.end());
  return out;
}

std::string binary_size(double bytes) {
  const double kib = bytes / 1024;
  return kib >= 1024 ? std::to_string(int(kib / 1024)) + " MiB" : std::to_string(int(kib)) + " KiB";
}

// A campaign of real scenes, which a fresh clone has not fetched (loading it would
// refuse them), read from a copy whose scene axis is one built-in scene. The axes the
// docs state do not depend on the scene; the job count is per scene.
rtsim::Campaign load_on_one_builtin_scene(const std::string& file) {
  std::string text = read_all(kSource / "campaigns" / file);
  const std::regex scene_line(R"(\nscene = [^\n]*)");
  if (!std::regex_search(text, scene_line)) throw std::runtime_error(file + ": no scene line");
  text = std::regex_replace(text, scene_line, "\nscene = \"interior\"");
  const fs::path copy = fs::temp_directory_path() / ("docs-agree-" + std::to_string(::getpid()) + "-" + file);
  std::ofstream(copy) << text;
  const rtsim::Campaign c = rtsim::load_campaign(copy, "rev");
  fs::remove(copy);
  return c;
}

}  // namespace

TEST(DocsAgree, TheExampleCampaignIsAsDocumented) {
  const rtsim::Campaign c = rtsim::load_campaign(kSource / "campaigns" / "example.toml", "rev");
  // One line of prose however the paragraph is wrapped.
  const std::string text = std::regex_replace(section(read_all(kSource / "docs" / "campaigns.md"),
                                                      "## The example campaign"),
                                              std::regex(R"(\s+)"), " ");
  ASSERT_FALSE(text.empty());
  std::set<std::string> resolutions, presets, builders;
  for (const auto& j : c.jobs) resolutions.insert(j.resolution), presets.insert(j.preset), builders.insert(j.builder);
  ASSERT_EQ(resolutions.size(), 1u);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(text, m, std::regex(R"((\d+)x(\d+))"))) << text;
  EXPECT_EQ(m.str(0), *resolutions.begin()) << "the resolution the docs give";
  ASSERT_TRUE(std::regex_search(text, m, std::regex(R"((\d+) jobs)"))) << text;
  EXPECT_EQ(std::stoul(m[1]), c.jobs.size()) << "the job count the docs give";
  const std::vector<double> l2 = override_values(c, "l2.size_bytes");
  ASSERT_FALSE(l2.empty());
  EXPECT_NE(text.find(binary_size(l2.front()) + " to " + binary_size(l2.back())), std::string::npos)
      << "the L2 sweep is " << binary_size(l2.front()) << " to " << binary_size(l2.back()) << ":\n" << text;
  for (const std::string& b : builders) EXPECT_NE(text.find(b), std::string::npos) << b;
  for (const std::string& p : presets) EXPECT_NE(text.find("`" + p + "`"), std::string::npos) << p;
  // The file's own description says the same resolution.
  EXPECT_NE(c.description.find(*resolutions.begin()), std::string::npos) << c.description;
}

TEST(DocsAgree, TheGpuScalingRangeIsAsDocumented) {
  const rtsim::Campaign c = load_on_one_builtin_scene("gpu-scaling.toml");
  const std::vector<double> cores = override_values(c, "cores");
  ASSERT_GE(cores.size(), 2u);
  const std::string range = std::to_string(int(cores.front())) + ".." + std::to_string(int(cores.back()));
  const std::string words = "from " + std::to_string(int(cores.front())) + " to " + std::to_string(int(cores.back()));
  EXPECT_NE(c.description.find(range), std::string::npos) << c.description;
  const std::string machine = read_all(kSource / "docs" / "machine.md");
  const size_t at = machine.find("`campaigns/gpu-scaling.toml` sweeps `cores` ");
  ASSERT_NE(at, std::string::npos);
  EXPECT_EQ(machine.substr(at + 44, words.size()), words) << machine.substr(at, 120);
}

TEST(DocsAgree, TheRayReorderingCampaignIsAsDocumented) {
  const rtsim::Campaign c = load_on_one_builtin_scene("ray-reordering.toml");
  const std::string text = std::regex_replace(section(read_all(kSource / "docs" / "machine.md"), "## Ray reordering"),
                                              std::regex(R"(\s+)"), " ");
  ASSERT_FALSE(text.empty());
  std::smatch m;
  ASSERT_TRUE(std::regex_search(text, m, std::regex(R"((\d+) jobs)"))) << text;
  EXPECT_EQ(std::stoul(m[1]), 3 * c.jobs.size()) << "three scenes of this many jobs each";
  // Every batch size the campaign runs has rows in the table, and no other does.
  std::set<int> swept, tabled;
  for (double b : override_values(c, "reorder.batch_rays"))
    if (b > 0) swept.insert(int(b));
  const std::regex row(R"(\| (\d+) \| [+-]\d)");  // "| B | +x%, ..."
  for (auto it = std::sregex_iterator(text.begin(), text.end(), row);
       it != std::sregex_iterator(); ++it)
    tabled.insert(std::stoi((*it)[1]));
  EXPECT_EQ(swept, tabled);
}

// Every flag shown after `rtsim SUBCOMMAND` in the docs is one that subcommand has,
// under its current name.
TEST(DocsAgree, EveryFlagTheDocsShowIsTheCommandsOwn) {
  CLI::App app;
  rtsim::cli::add_rtsim_commands(app);
  std::vector<fs::path> docs = {kSource / "README.md"};
  for (const auto& e : fs::directory_iterator(kSource / "docs"))
    if (e.path().extension() == ".md") docs.push_back(e.path());
  // "rtsim" then words (whole words: not ~/.cache/rtsim build/bench), then the line.
  const std::regex command(R"(rtsim((?: [a-z][a-z0-9-]*(?=[\s`\]|]|$))+)([^`\n]*))");
  // A flag, not a value of one (--sbatch-option=--partition=short).
  const std::regex flag(R"((^|[^=a-z0-9-])--([a-z][a-z0-9-]*))");
  size_t checked = 0;
  for (const fs::path& doc : docs) {
    const std::string text = read_all(doc);
    for (auto it = std::sregex_iterator(text.begin(), text.end(), command); it != std::sregex_iterator(); ++it) {
      // The deepest subcommand the words name, and the rest of the line after it.
      std::istringstream words((*it)[1]);
      const CLI::App* sub = &app;
      std::string rest, word;
      std::string path = "rtsim";
      while (words >> word) {
        const CLI::App* deeper = nullptr;
        for (const CLI::App* s : sub->get_subcommands({})) if (s->get_name() == word) deeper = s;
        if (!deeper) { rest += " " + word; continue; }
        if (!rest.empty()) break;
        sub = deeper, path += " " + word;
      }
      if (sub == &app) continue;  // "rtsim" in prose, not a command
      rest += (*it)[2].str();
      for (auto f = std::sregex_iterator(rest.begin(), rest.end(), flag); f != std::sregex_iterator(); ++f) {
        const std::string name = (*f)[2];
        const CLI::Option* option = nullptr;
        for (const CLI::App* a = sub; a && !option; a = a->get_parent())
          for (const CLI::Option* o : a->get_options())
            for (const std::string& l : o->get_lnames()) if (l == name) option = o;
        EXPECT_NE(option, nullptr) << doc.filename() << ": `" << path << " --" << name << "`: no such flag";
        if (option)
          EXPECT_EQ(option->get_group().find("Deprecated"), std::string::npos)
              << doc.filename() << ": `" << path << " --" << name << "` is a deprecated spelling";
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 50u);
}

// docs/dram.md's table of parts gives the numbers the model's parts table holds:
// each row's integers, part by part in the header's order.
TEST(DocsAgree, TheDramPartsTableIsTheModels) {
  const std::string doc = section(read_all(kSource / "docs" / "dram.md"), "## Parts and their sources");
  ASSERT_FALSE(doc.empty());
  auto cells = [&](const std::string& row_name) {
    std::vector<std::string> out;
    const size_t at = doc.find(row_name.empty() ? std::string("| |") : "| " + row_name + " |");
    if (at == std::string::npos) return out;
    std::string line = doc.substr(at, doc.find('\n', at) - at);
    std::stringstream in(line);
    std::string cell;
    std::getline(in, cell, '|');  // before the first bar
    std::getline(in, cell, '|');  // the row's name
    while (std::getline(in, cell, '|'))
      if (cell.find_first_not_of(' ') != std::string::npos) out.push_back(cell);
    return out;
  };
  auto numbers = [](const std::string& text) {
    std::vector<uint64_t> out;
    static const std::regex integer(R"(\d+)");
    for (std::sregex_iterator it(text.begin(), text.end(), integer), end; it != end; ++it)
      out.push_back(std::stoull(it->str()));
    return out;
  };
  const std::vector<std::string> header = cells("");
  const auto& parts = rtsim::sim::dram_parts();
  ASSERT_EQ(header.size(), parts.size()) << doc.substr(0, 400);
  for (size_t i = 0; i < parts.size(); ++i) {
    const rtsim::sim::DramPart& p = parts[i];
    SCOPED_TRACE(p.name);
    EXPECT_NE(header[i].find(p.name), std::string::npos) << header[i];
    const std::map<std::string, std::vector<uint64_t>> rows = {
        {"tCK (ps)", {p.tck_ps}},
        {"bank groups x banks", {p.bank_groups, p.banks / p.bank_groups}},
        {"CL / CWL", {p.tcl, p.tcwl}},
        {"tRCD (write) / tRP / tRAS", {p.trcd, p.trcd_write, p.trp, p.tras}},
        {"tRRD_S / tRRD_L / tFAW", {p.trrd_s, p.trrd_l, p.tfaw}},
        {"tCCD_S / tCCD_L", {p.tccd_s, p.tccd_l}},
        {"tWTR_S / tWTR_L / tWR / tRTP", {p.twtr_s, p.twtr_l, p.twr, p.trtp}},
        {"tRTRS", {p.trtrs}},
        {"tREFI / tRFC", {p.trefi, p.trfc}}};
    for (const auto& [row, expected] : rows) {
      const std::vector<std::string> c = cells(row);
      ASSERT_EQ(c.size(), parts.size()) << row;
      EXPECT_EQ(numbers(c[i]), expected) << row << ": " << c[i];
    }
  }
}
