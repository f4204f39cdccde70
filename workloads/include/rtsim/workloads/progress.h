#pragma once
// Progress for long work: a one-line bar on a terminal (stderr), silent when
// stderr is not a terminal (CI logs, pipes). Thread-safe `advance`.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

namespace rtsim {

class Progress {
 public:
  Progress(std::string label, uint64_t total, std::string unit = "items");
  ~Progress();  // finishes the line
  void advance(uint64_t n = 1);
  static bool enabled();  // stderr is a terminal and RTSIM_NO_PROGRESS is unset

 private:
  void draw(uint64_t done, bool final);
  std::string label_, unit_;
  uint64_t total_;
  std::atomic<uint64_t> done_{0};
  std::atomic<int64_t> last_draw_ns_{0};
  std::chrono::steady_clock::time_point start_;
  bool enabled_;
};

}  // namespace rtsim
