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

}  // namespace rtsim
