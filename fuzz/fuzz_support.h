#pragma once
// Shared by the libFuzzer targets: a private scratch folder for the readers that
// take paths, and the one rule every target checks - bad input may only ever
// raise rtsim::InputError; any other exception escapes to libFuzzer (a finding),
// as do crashes, hangs and sanitizer reports.
#include <rtsim/workloads/error.h>

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace rtsim::fuzz {

// One folder per process (libFuzzer -fork/-jobs run several), under /dev/shm
// when it exists so the file-based readers stay fast.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    const std::filesystem::path base =
        std::filesystem::exists("/dev/shm") ? std::filesystem::path("/dev/shm") : std::filesystem::temp_directory_path();
    std::filesystem::path d = base / ("rtsim-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

inline void write_bytes(const std::filesystem::path& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
}
inline void write_text(const std::filesystem::path& path, const std::string& text) {
  write_bytes(path, reinterpret_cast<const uint8_t*>(text.data()), text.size());
}

// Runs fn; an InputError is the documented answer to bad input and is swallowed.
template <class F>
void expect_only_input_errors(F&& fn) {
  try {
    fn();
  } catch (const InputError&) {
  }
}

}  // namespace rtsim::fuzz

// RTSIM_FUZZ_TARGET(name) { body using data, size } defines rtsim_fuzz_<name>()
// and, unless RTSIM_FUZZ_REPLAY is defined, the libFuzzer entry point calling it.
// tests/robustness/test_fuzz_regressions.cpp defines RTSIM_FUZZ_REPLAY and
// includes every target, so saved inputs replay through the very same code.
#ifdef RTSIM_FUZZ_REPLAY
#define RTSIM_FUZZ_ENTRY(name)
#else
#define RTSIM_FUZZ_ENTRY(name)                                                  \
  extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {   \
    return rtsim_fuzz_##name(data, size);                                       \
  }
#endif
#define RTSIM_FUZZ_TARGET(name)                          \
  int rtsim_fuzz_##name(const uint8_t* data, size_t size); \
  RTSIM_FUZZ_ENTRY(name)                                 \
  int rtsim_fuzz_##name(const uint8_t* data, size_t size)
