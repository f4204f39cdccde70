#include <rtsim/workloads/error.h>
#include <rtsim/workloads/host.h>
#include <rtsim/workloads/numbers.h>

#include <cstdio>
#include <cstdlib>

#include <sys/resource.h>
#include <unistd.h>

namespace rtsim {

uint64_t peak_memory_bytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

uint64_t parse_memory_size(const std::string& text, const std::string& where) {
  std::string digits = text;
  int shift = 0;
  if (!digits.empty()) {
    switch (digits.back()) {
      case 'K': shift = 10; break;
      case 'M': shift = 20; break;
      case 'G': shift = 30; break;
      case 'T': shift = 40; break;
      default: break;
    }
    if (shift) digits.pop_back();
  }
  uint64_t value = 0;
  if (!parse_unsigned(digits, 1, UINT64_MAX >> shift, value))
    throw InputError(where, "expected a size: a whole number of bytes >= 1, or one with K, M, G or T "
                            "(binary units, e.g. 64G), got '" + text + "'");
  return value << shift;
}

uint64_t memory_limit_bytes() {
  if (const char* text = std::getenv(kMemoryLimitVariable); text && *text)
    return parse_memory_size(text, kMemoryLimitVariable);
  const long pages = ::sysconf(_SC_PHYS_PAGES), page_size = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page_size <= 0) return UINT64_MAX;  // unknown: no limit rather than a wrong one
  return saturating_mul(uint64_t(pages), uint64_t(page_size)) / 2;
}

std::string memory_text(uint64_t bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  double value = double(bytes);
  int unit = 0;
  while (value >= 1024.0 && unit < 6) value /= 1024.0, ++unit;
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, unit == 0 ? "%.0f %s" : "%.1f %s", value, units[unit]);
  return buffer;
}

void check_memory_budget(uint64_t bytes, const std::string& what, const std::string& factors) {
  const uint64_t limit = memory_limit_bytes();
  if (bytes <= limit) return;
  throw InputError(what, "needs about " + (bytes == UINT64_MAX ? std::string("more than 16 EiB") : memory_text(bytes)) +
                             " (" + factors + "), over the memory limit of " + memory_text(limit) + " (" +
                             kMemoryLimitVariable + " or rtsim --memory-limit raise it)");
}

}  // namespace rtsim
