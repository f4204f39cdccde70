#include <rtsim/reports/text_table.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rtsim {

namespace {
bool looks_numeric(const std::string& s) {
  if (s.empty()) return false;
  char* end = nullptr;
  std::strtod(s.c_str(), &end);
  return end && (*end == 0 || *end == '%' || *end == ' ' || *end == 'x');
}
}  // namespace

std::string TextTable::plain() const {
  std::vector<size_t> width(header_.size(), 0);
  for (size_t c = 0; c < header_.size(); ++c) width[c] = header_[c].size();
  for (const auto& row : rows_)
    for (size_t c = 0; c < row.size() && c < width.size(); ++c) width[c] = std::max(width[c], row[c].size());
  auto line = [&](const std::vector<std::string>& cells, bool header) {
    std::string out;
    for (size_t c = 0; c < width.size(); ++c) {
      const std::string cell = c < cells.size() ? cells[c] : "";
      const std::string pad(width[c] - cell.size(), ' ');
      out += (c ? "  " : "") + (!header && looks_numeric(cell) ? pad + cell : cell + pad);
    }
    while (!out.empty() && out.back() == ' ') out.pop_back();
    return out + "\n";
  };
  std::string out = line(header_, true);
  size_t total = 0;
  for (size_t w : width) total += w + 2;
  out += std::string(total > 2 ? total - 2 : 0, '-') + "\n";
  for (const auto& row : rows_) out += line(row, false);
  return out;
}

std::string TextTable::markdown() const {
  auto line = [](const std::vector<std::string>& cells) {
    std::string out = "|";
    for (const std::string& c : cells) out += " " + c + " |";
    return out + "\n";
  };
  std::string out = line(header_) + "|";
  for (size_t c = 0; c < header_.size(); ++c) out += c ? "---:|" : "---|";
  out += "\n";
  for (const auto& row : rows_) out += line(row);
  return out;
}

std::string TextTable::csv() const {
  auto cell = [](const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string q = "\"";
    for (char ch : s) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
    return q + "\"";
  };
  auto line = [&](const std::vector<std::string>& cells) {
    std::string out;
    for (size_t c = 0; c < cells.size(); ++c) out += (c ? "," : "") + cell(cells[c]);
    return out + "\n";
  };
  std::string out = line(header_);
  for (const auto& row : rows_) out += line(row);
  return out;
}

std::string format_number(double value, int digits) {
  if (!std::isfinite(value)) return std::isnan(value) ? "nan" : (value > 0 ? "inf" : "-inf");
  char buf[64];
  const double magnitude = std::fabs(value);
  if (magnitude != 0.0 && (magnitude >= 1e9 || magnitude < 1e-3))
    std::snprintf(buf, sizeof buf, "%.*e", std::max(digits - 1, 0), value);
  else if (magnitude < 1.0)
    std::snprintf(buf, sizeof buf, "%.*g", std::max(digits, 1), value);  // 0.001234 keeps its digits
  else {
    const int int_digits = int(std::floor(std::log10(magnitude))) + 1;
    std::snprintf(buf, sizeof buf, "%.*f", std::max(digits - int_digits, 0), value);
  }
  return buf;
}

std::string format_significant(double value, int digits) {
  if (value == 0 || std::fabs(value) >= 1 || !std::isfinite(value)) return format_number(value, digits);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*g", digits, value);
  return buf;
}

std::string format_percent(double fraction, int digits) { return format_significant(100.0 * fraction, digits) + "%"; }

}  // namespace rtsim
