#pragma once
// Deterministic randomness keyed by ids: every random choice draws from a hash of
// (seed, key...) so results never depend on thread count or evaluation order.
#include <cstdint>
#include <cstring>
#include <initializer_list>

namespace rtsim {

// SplitMix64 finaliser: a good 64-bit mixer, cheap enough for per-sample use.
constexpr uint64_t mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// A 64-bit content hash of a byte range, chained through `h`: keys caches and
// result files to their inputs (scenes, trees, configuration files).
inline uint64_t hash_bytes(uint64_t h, const void* data, size_t size) {
  const auto* p = static_cast<const unsigned char*>(data);
  size_t i = 0;
  for (; i + 8 <= size; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = mix64(h ^ w);
  }
  uint64_t tail = 0;
  std::memcpy(&tail, p + i, size - i);
  return mix64(h ^ tail ^ (uint64_t(size) << 56));
}

// A small generator whose stream is fixed by its keys, e.g.
// KeyedRng rng(seed, {pixel, sample, bounce});
class KeyedRng {
 public:
  KeyedRng(uint64_t seed, std::initializer_list<uint64_t> keys) : state_(mix64(seed)) {
    for (uint64_t k : keys) state_ = mix64(state_ ^ mix64(k));
  }
  uint64_t next_u64() {
    state_ += 0x9E3779B97F4A7C15ull;
    uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform float in [0, 1): the top 24 bits, so 1.0 is never returned.
  float next_float() { return float(next_u64() >> 40) * (1.0f / 16777216.0f); }

 private:
  uint64_t state_;
};

}  // namespace rtsim
