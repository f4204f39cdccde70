#pragma once
// Aligned plain-text and Markdown tables for terminal output and reports.
#include <string>
#include <vector>

namespace rtsim {

class TextTable {
 public:
  explicit TextTable(std::vector<std::string> header) : header_(std::move(header)) {}
  void add_row(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
  std::string plain() const;     // columns padded; numbers right-aligned
  std::string markdown() const;  // GitHub-flavoured Markdown
  std::string csv() const;       // RFC 4180 quoting

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

// Formats a number with `digits` significant digits (no exponent for ordinary sizes).
std::string format_number(double value, int digits = 4);

// As format_number, but below 1e-3 without zeros padding the mantissa (0.00001 ->
// "1e-05", where format_number gives "1.00e-05"): the accuracy report's small times
// and errors.
std::string format_significant(double value, int digits = 4);
// A fraction as a percentage with `digits` significant digits (0.0123 -> "1.23%").
std::string format_percent(double fraction, int digits = 3);

}  // namespace rtsim
