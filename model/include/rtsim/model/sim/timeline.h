#pragma once
// A timeline of a timed run (lt or cycle) in the Chrome / Perfetto trace-event
// format: JSON that Perfetto, chrome://tracing and speedscope open. One track (a
// "thread" of the format) per unit instance, cache, crossbar port and DRAM channel,
// grouped by core and memory (its "processes"); complete events ("ph": "X") with
// times in microseconds of simulated time, to the picosecond.
//
// Bounded: only spans that overlap the window [from, to) are written (clipped to
// it), and at most max_events of them; the first span past the cap stops the
// writing, and the file says where (otherData.rtsim.capped_at_cycle).
// Written to a temporary file beside the target and renamed into place by close(),
// so a failed run leaves no half-written timeline.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace rtsim::sim {

struct TimelineOptions {
  std::filesystem::path file;
  uint64_t from_ps = 0, to_ps = UINT64_MAX;  // the window
  uint64_t max_events = 1'000'000;
  double cycle_ps = 1000;  // the accelerator's clock, so the file can say cycles
  std::string level;       // "lt" | "cycle"
};

class Timeline {
 public:
  static constexpr uint64_t kDefaultMaxEvents = 1'000'000;
  // Throws InputError naming --timeline if the file cannot be created.
  explicit Timeline(TimelineOptions options);
  ~Timeline();  // without close(): the temporary file is removed
  Timeline(const Timeline&) = delete;
  Timeline& operator=(const Timeline&) = delete;

  // A track: one row of the viewer under `group`. Spans of a plain track never
  // overlap (a unit's states); a laned track takes overlapping spans (misses in
  // flight, crossbar messages) on as many rows as they need, "name", "name #2", ...
  uint32_t track(const std::string& group, const std::string& name, bool laned = false);
  // [start, end) on the track; args: a JSON object's members ("\"line\":\"0x40\"") or empty.
  void span(uint32_t track, const char* name, uint64_t start_ps, uint64_t end_ps,
            const std::string& args = std::string());
  // The track names, the window and the cap into the file; the file into place.
  void close();

  uint64_t events() const { return events_; }
  bool capped() const { return capped_; }
  uint64_t capped_at_ps() const { return capped_at_ps_; }
  uint64_t lane_overflows() const { return lane_overflows_; }  // spans of a track past its rows
  const TimelineOptions& options() const { return options_; }

 private:
  struct Track {
    uint32_t group;
    std::string name;
    bool laned;
    std::vector<uint32_t> lanes;     // the rows' thread ids
    std::vector<uint64_t> lane_end;  // where each row's last span ends
  };
  uint32_t new_row(uint32_t track, uint32_t lane);
  void write_event(uint32_t group, uint32_t row, const char* name, uint64_t start_ps, uint64_t end_ps,
                   const std::string& args);

  TimelineOptions options_;
  std::filesystem::path temporary_;
  std::FILE* out_ = nullptr;
  std::vector<char> buffer_;
  std::vector<std::string> groups_;
  std::vector<Track> tracks_;
  struct Row {
    uint32_t group, track, lane;
    std::string name;
  };
  std::vector<Row> rows_;  // by thread id - 1
  uint64_t events_ = 0, lane_overflows_ = 0, capped_at_ps_ = 0;
  bool capped_ = false, closed_ = false;
};

}  // namespace rtsim::sim
