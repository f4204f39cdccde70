#include <rtsim/workloads/progress.h>

#include <cstdio>
#include <cstdlib>
#include <unistd.h>

namespace rtsim {

bool Progress::enabled() {
  static const bool on = ::isatty(STDERR_FILENO) && !std::getenv("RTSIM_NO_PROGRESS");
  return on;
}

Progress::Progress(std::string label, uint64_t total, std::string unit)
    : label_(std::move(label)), unit_(std::move(unit)), total_(total),
      start_(std::chrono::steady_clock::now()), enabled_(enabled()) {}

Progress::~Progress() {
  if (enabled_) draw(done_.load(), true);
}

void Progress::advance(uint64_t n) {
  const uint64_t done = done_.fetch_add(n) + n;
  if (!enabled_) return;
  const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::steady_clock::now() - start_).count();
  int64_t last = last_draw_ns_.load();
  // Redraw at most 10 times a second; only the thread that wins the exchange draws.
  if (now - last > 100'000'000 && last_draw_ns_.compare_exchange_strong(last, now))
    draw(done, false);
}

void Progress::draw(uint64_t done, bool final) {
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = seconds > 0 ? done / seconds : 0.0;
  const double fraction = total_ ? double(done) / double(total_) : 1.0;
  const double eta = rate > 0 && total_ > done ? (total_ - done) / rate : 0.0;
  char bar[31];
  const int filled = int(fraction * 30 + 0.5);
  for (int i = 0; i < 30; ++i) bar[i] = i < filled ? '#' : '.';
  bar[30] = 0;
  std::fprintf(stderr, "\r%-24s [%s] %5.1f%%  %.3g %s/s  ETA %.0fs   %s", label_.c_str(), bar,
               100.0 * fraction, rate, unit_.c_str(), eta, final ? "\n" : "");
  std::fflush(stderr);
}

}  // namespace rtsim
