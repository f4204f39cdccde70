// Strict config reading: errors name the file and the dotted key.
#include <rtsim/workloads/config_reader.h>
#include <rtsim/workloads/error.h>

#include <gtest/gtest.h>

using namespace rtsim;

namespace {
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(ConfigReader, TomlAndJsonReadTheSame) {
  const auto t = parse_config_text("a = 1\n[b]\nc = [1.0, 2.0, 3.0]\n", "x.toml", true);
  const auto j = parse_config_text(R"({"a": 1, "b": {"c": [1.0, 2.0, 3.0]}})", "x.json", false);
  EXPECT_EQ(t, j);
}

TEST(ConfigReader, SyntaxErrorNamesFileAndLine) {
  const std::string e = error_of([] { parse_config_text("a = 1\nb = = 2\n", "bad.toml", true); });
  EXPECT_NE(e.find("bad.toml:2"), std::string::npos) << e;
}

TEST(ConfigReader, UnknownKeyIsRefusedByName) {
  const auto doc = parse_config_text("[dram]\ntcl = 14\ntypo = 3\n", "hw.toml", true);
  ConfigTable root(doc, "hw.toml");
  ConfigTable dram = root.table("dram");
  EXPECT_EQ(dram.integer("tcl", 0, 1, 100), 14);
  const std::string e = error_of([&] { dram.finish(); });
  EXPECT_NE(e.find("hw.toml"), std::string::npos) << e;
  EXPECT_NE(e.find("dram.typo"), std::string::npos) << e;
}

TEST(ConfigReader, OutOfRangeAndWrongTypeNameTheKey) {
  const auto doc = parse_config_text("x = 500\ny = \"s\"\nv = [1, 2]\n", "c.toml", true);
  ConfigTable root(doc, "c.toml");
  std::string e = error_of([&] { root.integer("x", 0, 0, 100); });
  EXPECT_NE(e.find("'x'"), std::string::npos) << e;
  EXPECT_NE(e.find("out of range"), std::string::npos) << e;
  e = error_of([&] { root.number("y", 0, 0, 1); });
  EXPECT_NE(e.find("'y'"), std::string::npos) << e;
  e = error_of([&] { root.vector3("v"); });
  EXPECT_NE(e.find("'v'"), std::string::npos) << e;
  e = error_of([&] { root.string("missing"); });
  EXPECT_NE(e.find("required"), std::string::npos) << e;
}

TEST(ConfigReader, ArrayOfTablesPathsAreIndexed) {
  const auto doc = parse_config_text("[[camera]]\nname = \"a\"\n[[camera]]\nfov = 500\n", "s.toml", true);
  ConfigTable root(doc, "s.toml");
  auto cams = root.array_of_tables("camera");
  ASSERT_EQ(cams.size(), 2u);
  const std::string e = error_of([&] { cams[1].number("fov", 60, 1, 179); });
  EXPECT_NE(e.find("camera[1].fov"), std::string::npos) << e;
}
