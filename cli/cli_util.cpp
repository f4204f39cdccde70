#include "cli_util.h"

#include <rtsim/workloads/error.h>

#include <cstdio>

namespace rtsim::cli {

void parse_resolution(const std::string& text, uint32_t& width, uint32_t& height,
                      const std::string& option) {
  unsigned w = 0, h = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%u%c%u%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') ||
      w == 0 || h == 0 || w > 16384 || h > 16384)
    throw InputError(option, "expected WxH with 1..16384 each, got '" + text + "'");
  width = w;
  height = h;
}

std::string hex64(uint64_t value) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(value));
  return buf;
}

}  // namespace rtsim::cli
