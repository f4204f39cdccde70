#pragma once
// What a run costs the host: every result reports peak memory and host seconds;
// and what a run may plan to cost before it allocates (the memory limit).
#include <cstdint>
#include <string>

namespace rtsim {

uint64_t peak_memory_bytes();  // peak resident set size of this process so far

// The memory limit (docs/robustness.md "Resource bounds"): the most memory one
// rtsim process may plan to use. RTSIM_MEMORY_LIMIT if set (bytes, or a whole
// number with K, M, G or T, binary units), else half of the machine's physical
// memory. `rtsim --memory-limit SIZE` sets RTSIM_MEMORY_LIMIT for itself and for
// the processes it starts. InputError naming the variable if it is not a size.
constexpr const char* kMemoryLimitVariable = "RTSIM_MEMORY_LIMIT";
uint64_t memory_limit_bytes();
// "64G" -> 64 << 30; InputError(where, ...) if not a size.
uint64_t parse_memory_size(const std::string& text, const std::string& where);
// "2.5 GiB", "12 MiB", "512 B".
std::string memory_text(uint64_t bytes);

// Refuses, before anything is allocated, a plan that needs more than the limit:
// InputError(what, "needs about 64 TiB (FACTORS), over the memory limit of ...").
// `factors` names the keys or flags that multiply.
void check_memory_budget(uint64_t bytes, const std::string& what, const std::string& factors);

// a * b, saturating at UINT64_MAX: estimates of hostile sizes must not wrap.
inline uint64_t saturating_mul(uint64_t a, uint64_t b) {
  return a != 0 && b > UINT64_MAX / a ? UINT64_MAX : a * b;
}
inline uint64_t saturating_add(uint64_t a, uint64_t b) { return b > UINT64_MAX - a ? UINT64_MAX : a + b; }

}  // namespace rtsim
