// Number formatting and tables used by every report.
#include <rtsim/reports/text_table.h>

#include <gtest/gtest.h>

#include <cmath>

using rtsim::format_number;

TEST(FormatNumber, KeepsSignificantDigitsAtEveryMagnitude) {
  EXPECT_EQ(format_number(24.0123, 4), "24.01");
  EXPECT_EQ(format_number(1234.6, 4), "1235");
  EXPECT_EQ(format_number(0.0012345, 3), "0.00123");
  EXPECT_EQ(format_number(0.5, 4), "0.5");
  EXPECT_EQ(format_number(0.0, 4), "0");
  EXPECT_EQ(format_number(NAN), "nan");
  EXPECT_NE(format_number(1e-7, 3).find('e'), std::string::npos);
}

TEST(TextTable, CsvQuotesAndMarkdownAligns) {
  rtsim::TextTable t({"a", "b"});
  t.add_row({"x,y", "say \"hi\""});
  EXPECT_EQ(t.csv(), "a,b\n\"x,y\",\"say \"\"hi\"\"\"\n");
  EXPECT_NE(t.markdown().find("|---|---:|"), std::string::npos);
}
