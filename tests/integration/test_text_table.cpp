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

// The accuracy report's formatter (its two files share it): below 1e-3 no zeros
// padding the mantissa, and format_number's output from 1e-3 up.
TEST(FormatSignificant, KeepsSmallValuesShortAndAgreesWithFormatNumberElsewhere) {
  EXPECT_EQ(rtsim::format_significant(0.00001, 3), "1e-05");
  EXPECT_EQ(format_number(0.00001, 3), "1.00e-05");
  EXPECT_EQ(rtsim::format_significant(0.0000123, 3), "1.23e-05");
  for (double v : {0.0, 0.0012345, 0.5, 1.0, 24.0123, 1234.6, 5e9, -0.25})
    EXPECT_EQ(rtsim::format_significant(v, 4), format_number(v, 4)) << v;
  EXPECT_EQ(rtsim::format_significant(NAN), "nan");
  EXPECT_EQ(rtsim::format_percent(0.0123), "1.23%");
  EXPECT_EQ(rtsim::format_percent(-0.5, 2), "-50%");
}

TEST(TextTable, CsvQuotesAndMarkdownAligns) {
  rtsim::TextTable t({"a", "b"});
  t.add_row({"x,y", "say \"hi\""});
  EXPECT_EQ(t.csv(), "a,b\n\"x,y\",\"say \"\"hi\"\"\"\n");
  EXPECT_NE(t.markdown().find("|---|---:|"), std::string::npos);
}
