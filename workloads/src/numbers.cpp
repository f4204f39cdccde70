#include <rtsim/workloads/error.h>
#include <rtsim/workloads/numbers.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace rtsim {

namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// Length of the JSON integer grammar's digits part at `at`: 0|[1-9][0-9]*.
// 0 if there is none; a leading zero followed by more digits counts as none.
size_t digits_at(std::string_view text, size_t at) {
  size_t end = at;
  while (end < text.size() && is_digit(text[end])) ++end;
  if (end == at || (text[at] == '0' && end - at > 1)) return 0;
  return end - at;
}

std::string quoted(std::string_view text) { return "'" + std::string(text) + "'"; }

std::string range_reason(std::string_view text, const std::string& min, const std::string& max) {
  return "value " + std::string(text) + " is out of range [" + min + ", " + max + "]";
}

std::string real_text(double v) {
  if (v == std::numeric_limits<double>::max()) return "max";
  if (v == -std::numeric_limits<double>::max()) return "-max";
  char buffer[32];
  const auto [end, error] = std::to_chars(buffer, buffer + sizeof buffer, v);
  return error == std::errc() ? std::string(buffer, end) : std::to_string(v);
}

}  // namespace

std::string unsigned_syntax_problem(std::string_view text) {
  if (text.empty()) return "expected a whole number, got nothing";
  if (text.front() == '-') return "must not be negative, got " + quoted(text);
  const size_t n = digits_at(text, 0);
  if (n == 0 || n != text.size())
    return "expected decimal digits only (no sign, no leading zero, no 0x), got " + quoted(text);
  return "";
}

std::string signed_syntax_problem(std::string_view text) {
  if (text.empty()) return "expected a whole number, got nothing";
  const size_t sign = text.front() == '-' ? 1 : 0;
  const size_t n = digits_at(text, sign);
  if (n == 0 || sign + n != text.size())
    return "expected decimal digits with an optional '-' (no '+', no leading zero, no 0x), got " + quoted(text);
  return "";
}

std::string real_syntax_problem(std::string_view text) {
  if (text.empty()) return "expected a number, got nothing";
  size_t at = text.front() == '-' ? 1 : 0;
  const size_t n = digits_at(text, at);
  bool ok = n > 0;
  at += n;
  if (ok && at < text.size() && text[at] == '.') {
    const size_t start = ++at;
    while (at < text.size() && is_digit(text[at])) ++at;
    ok = at > start;
  }
  if (ok && at < text.size() && (text[at] == 'e' || text[at] == 'E')) {
    ++at;
    if (at < text.size() && (text[at] == '+' || text[at] == '-')) ++at;
    const size_t start = at;
    while (at < text.size() && is_digit(text[at])) ++at;
    ok = at > start;
  }
  if (!ok || at != text.size())
    return "expected a decimal number such as 2, 0.5 or 1e-3 (no '+', no leading zero, no hex, nan or inf), got " +
           quoted(text);
  return "";
}

bool parse_unsigned(std::string_view text, uint64_t min, uint64_t max, uint64_t& out) {
  if (!unsigned_syntax_problem(text).empty()) return false;
  uint64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < min || value > max) return false;
  out = value;
  return true;
}

bool parse_signed(std::string_view text, int64_t min, int64_t max, int64_t& out) {
  if (!signed_syntax_problem(text).empty()) return false;
  int64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < min || value > max) return false;
  out = value;
  return true;
}

bool parse_real(std::string_view text, double min, double max, double& out) {
  if (!real_syntax_problem(text).empty()) return false;
  // strtod on a copy: the grammar above already refused what strtod alone would take.
  const std::string copy(text);
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(copy.c_str(), &end);
  if (end != copy.c_str() + copy.size() || !std::isfinite(value) || value < min || value > max) return false;
  if (errno == ERANGE && value != 0) return false;  // overflow (underflow to a tiny number is fine)
  out = value;
  return true;
}

uint64_t read_unsigned(std::string_view text, uint64_t min, uint64_t max, const std::string& where) {
  const std::string problem = unsigned_syntax_problem(text);
  if (!problem.empty()) throw InputError(where, problem);
  uint64_t value = 0;
  if (!parse_unsigned(text, min, max, value))
    throw InputError(where, range_reason(text, std::to_string(min), std::to_string(max)));
  return value;
}

int64_t read_signed(std::string_view text, int64_t min, int64_t max, const std::string& where) {
  const std::string problem = signed_syntax_problem(text);
  if (!problem.empty()) throw InputError(where, problem);
  int64_t value = 0;
  if (!parse_signed(text, min, max, value))
    throw InputError(where, range_reason(text, std::to_string(min), std::to_string(max)));
  return value;
}

double read_real(std::string_view text, double min, double max, const std::string& where) {
  const std::string problem = real_syntax_problem(text);
  if (!problem.empty()) throw InputError(where, problem);
  double value = 0;
  if (!parse_real(text, min, max, value)) throw InputError(where, range_reason(text, real_text(min), real_text(max)));
  return value;
}

bool parse_resolution_text(std::string_view text, uint32_t& width, uint32_t& height) {
  const size_t x = text.find_first_of("xX");
  if (x == std::string_view::npos) return false;
  uint64_t w = 0, h = 0;
  if (!parse_unsigned(text.substr(0, x), 1, kMaxResolutionSide, w) ||
      !parse_unsigned(text.substr(x + 1), 1, kMaxResolutionSide, h))
    return false;
  width = uint32_t(w);
  height = uint32_t(h);
  return true;
}

void read_size_text(std::string_view text, uint32_t max_side, const std::string& where, uint32_t& width,
                    uint32_t& height) {
  const size_t x = text.find_first_of("xX");
  uint64_t w = 0, h = 0;
  if (x == std::string_view::npos || !parse_unsigned(text.substr(0, x), 1, max_side, w) ||
      !parse_unsigned(text.substr(x + 1), 1, max_side, h))
    throw InputError(where, "expected WxH with 1.." + std::to_string(max_side) +
                                " each (decimal digits only), got '" + std::string(text) + "'");
  width = uint32_t(w);
  height = uint32_t(h);
}

}  // namespace rtsim
