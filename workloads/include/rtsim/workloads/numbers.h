#pragma once
// The one strict reader of numbers written as text: every command-line value,
// --build-set and campaign values, "WxH", environment variables and the text
// fields of files. A number is written as JSON (and TOML) write it:
//   integer  -?(0|[1-9][0-9]*)                  (no '-' where the value is unsigned)
//   real     integer(.[0-9]+)?([eE][+-]?[0-9]+)?  (finite; no nan, inf or hex)
// so "010" (octal to strtol), "0x10", "+2", " 2" and "" are refused, and a value
// past its range is refused, never wrapped or saturated.
#include <cstdint>
#include <string>
#include <string_view>

namespace rtsim {

bool parse_unsigned(std::string_view text, uint64_t min, uint64_t max, uint64_t& out);
bool parse_signed(std::string_view text, int64_t min, int64_t max, int64_t& out);
bool parse_real(std::string_view text, double min, double max, double& out);

// Why `text` is not a number of that kind at all ("" when it is one); a range
// check follows separately. For messages: "expected digits only, got '0x10'".
std::string unsigned_syntax_problem(std::string_view text);
std::string signed_syntax_problem(std::string_view text);
std::string real_syntax_problem(std::string_view text);

// The same readers, throwing InputError(where, reason) with the range in the reason.
uint64_t read_unsigned(std::string_view text, uint64_t min, uint64_t max, const std::string& where);
int64_t read_signed(std::string_view text, int64_t min, int64_t max, const std::string& where);
double read_real(std::string_view text, double min, double max, const std::string& where);

// "WxH" (or "WXH") with each side in 1..kMaxResolutionSide.
constexpr uint32_t kMaxResolutionSide = 16384;
bool parse_resolution_text(std::string_view text, uint32_t& width, uint32_t& height);
// "WxH" with each side in 1..max_side; InputError(where, ...) otherwise.
void read_size_text(std::string_view text, uint32_t max_side, const std::string& where, uint32_t& width,
                    uint32_t& height);

}  // namespace rtsim
