// Hardware configuration: presets, TOML overrides, refusal of unknown keys and
// out-of-range values, and the presets in model/presets/ matching the built-ins.
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/stats.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <sstream>

using namespace rtsim;
using namespace rtsim::sim;

namespace {
std::string error_of(const std::string& toml) {
  try {
    parse_hardware_config(toml, "test.toml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(SimConfig, PresetsDifferAndValidate) {
  const HardwareConfig mobile = preset("mobile");
  const HardwareConfig desktop = preset("desktop");
  EXPECT_EQ(mobile.dram.part, "lpddr4-3200");
  EXPECT_EQ(desktop.dram.part, "ddr4-2400");
  EXPECT_NO_THROW(validate(mobile));
  EXPECT_NO_THROW(validate(desktop));
  EXPECT_NE(to_json(mobile), to_json(desktop));
}

TEST(SimConfig, OverridesApplyOnTopOfPresetAndDramPart) {
  const HardwareConfig c = parse_hardware_config(
      "preset = \"desktop\"\n[trv]\nunits = 3\n[dram]\npart = \"gddr6\"\ntcl = 30\n", "x.toml");
  EXPECT_EQ(c.preset, "desktop");
  EXPECT_EQ(c.trv_units, 3u);
  EXPECT_EQ(c.ist_units, preset("desktop").ist_units);  // untouched keys keep the preset
  EXPECT_EQ(c.dram.part, "gddr6");
  EXPECT_EQ(c.dram.tcl, 30u);                            // explicit key beats the part
  EXPECT_EQ(c.dram.trp, 27u);                            // the part's value
}

TEST(SimConfig, UnknownKeyIsRefusedByName) {
  const std::string e = error_of("[trv]\nunitz = 3\n");
  EXPECT_NE(e.find("trv.unitz"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key"), std::string::npos) << e;
}

TEST(SimConfig, OutOfRangeAndWrongTypeAreRefusedByName) {
  std::string e = error_of("[l2]\nassociativity = 0\n");
  EXPECT_NE(e.find("l2.associativity"), std::string::npos) << e;
  e = error_of("[trv]\nunits = 2.5\n");
  EXPECT_NE(e.find("trv.units"), std::string::npos) << e;
  e = error_of("[dram]\npart = \"sdram\"\n");
  EXPECT_NE(e.find("dram.part"), std::string::npos) << e;
  e = error_of("[l1_node]\nsize_bytes = 3000\n");
  EXPECT_NE(e.find("l1_node.size_bytes"), std::string::npos) << e;
  e = error_of("[dram]\naddress_mapping = \"row:bank:column:channel\"\n");
  EXPECT_NE(e.find("dram.address_mapping"), std::string::npos) << e;
  e = error_of("clock_mhz = \"fast\"\n");
  EXPECT_NE(e.find("clock_mhz"), std::string::npos) << e;
  e = error_of("[trv\nunits = 1\n");
  EXPECT_NE(e.find("test.toml"), std::string::npos) << e;
}

// The preset files are the generated listing of every parameter, word for word
// (RTSIM_WRITE_PRESETS=1 rewrites them after the table changed).
TEST(SimConfig, PresetFilesMatchBuiltInPresets) {
  for (const std::string& name : preset_names()) {
    const std::string path = std::string(RTSIM_SOURCE_DIR) + "/model/presets/" + name + ".toml";
    std::string sources;
    std::istringstream lines(preset_sources(name));
    for (std::string line; std::getline(lines, line);) sources += "# " + line + "\n";
    const std::string expected =
        "# rtsim hardware preset '" + name + "': every parameter with its value.\n"
        "# Generated from the parameter table (model/src/sim/config.cpp); a test checks\n"
        "# that this file and the built-in preset agree. Copy it to start a variant.\n#\n" +
        sources + to_documented_toml(preset(name));
    if (std::getenv("RTSIM_WRITE_PRESETS")) std::ofstream(path, std::ios::binary) << expected;
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_EQ(text.str(), expected) << path << " is stale: rerun with RTSIM_WRITE_PRESETS=1";
    const HardwareConfig from_file = load_hardware_config(path);
    EXPECT_EQ(to_json(from_file), to_json(preset(name))) << path;
  }
}

TEST(SimConfig, DocumentedTomlRoundTrips) {
  HardwareConfig c = preset("desktop");
  c.trv_nodes_per_cycle = 0.5;
  const HardwareConfig back = parse_hardware_config(to_documented_toml(c), "doc.toml");
  EXPECT_EQ(to_json(back), to_json(c));
}

TEST(SimStats, HierarchicalSortedJson) {
  StatsRegistry s;
  s.set("trv.unit1.ops", 5, "ops", "b");
  s.set("trv.unit0.ops", 7, "ops", "a");
  s.set_real("dram.bandwidth", 1.5, "GB/s", "c");
  const auto j = nlohmann::json::parse(s.to_json());
  EXPECT_EQ(j["trv"]["unit0"]["ops"]["value"], 7);
  EXPECT_EQ(j["dram"]["bandwidth"]["unit"], "GB/s");
  const std::string text = s.to_json();
  EXPECT_LT(text.find("dram"), text.find("trv"));
  EXPECT_LT(text.find("unit0"), text.find("unit1"));
}

// The DRAM parts table: each part's burst must carry what its data rate and channel
// width say (a typo in tCK, the burst length or the bus would break it), and the
// names are the ones dram.part accepts.
TEST(DramParts, EachBurstCarriesItsDataRateOverItsChannelWidth) {
  ASSERT_FALSE(dram_parts().empty());
  for (const DramPart& p : dram_parts()) {
    SCOPED_TRACE(p.name);
    const double transfers = double(p.data_rate_mtps) * 1e6 * double(p.burst_cycles) * double(p.tck_ps) * 1e-12;
    EXPECT_NEAR(double(p.channel_bits) / 8.0 * transfers, double(p.burst_bytes), 0.01 * p.burst_bytes);
    EXPECT_EQ(p.row_bytes & (p.row_bytes - 1), 0u) << "rows are a power of two bytes";
    EXPECT_EQ(p.banks % p.bank_groups, 0u);
    EXPECT_GT(std::string(p.timing_source).size(), 10u);
    EXPECT_GT(std::string(p.energy_source).size(), 10u);
    DramConfig d;
    apply_dram_part(d, p.name);
    EXPECT_EQ(d.part, p.name);
    EXPECT_EQ(d.tck_ps, p.tck_ps);
    EXPECT_EQ(d.burst_bytes, p.burst_bytes);
  }
  EXPECT_EQ(dram_part_names().size(), dram_parts().size());
  DramConfig d;
  try {
    apply_dram_part(d, "ddr9");
    ADD_FAILURE() << "an unknown part was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lpddr5"), std::string::npos) << e.what();
  }
}
