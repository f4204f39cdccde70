#pragma once
// Small pieces every subcommand parses or prints the same way.
#include <cstdint>
#include <string>

namespace rtsim::cli {

// "WxH" with 1..16384 each; InputError naming `option` otherwise.
void parse_resolution(const std::string& text, uint32_t& width, uint32_t& height,
                      const std::string& option = "--res");

std::string hex64(uint64_t value);  // 16 lower-case hex digits

}  // namespace rtsim::cli
