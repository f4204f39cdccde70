#include <rtsim/model/sim/timeline.h>
#include <rtsim/workloads/error.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <unistd.h>

namespace rtsim::sim {

namespace {
// A row per span at most this many deep: more spans in flight on one track than a
// viewer can show apart; the rest are counted, not drawn.
constexpr size_t kMaxLanes = 64;

// Times are written as multiples of 2^-20 microseconds (0.95 ps), each the nearest
// to its picosecond time. A viewer reads ts and dur as doubles, adds them, and
// speedscope also subtracts the file's first ts from every ts. With decimal
// microseconds those sums round (7.335244 + 0.000733 = 7.335977000000001 passes
// the next span's 7.335977) and speedscope then nests every later span of the row
// inside that one. Multiples of 2^-20 below 2^33 us (2.4 hours of simulated time)
// are doubles whose sums and differences are exact, so a span that ends where the
// next begins still does so however a viewer adds them. Each is within 0.48 ps of
// its time, so a reader rounding to picoseconds gets the time back.
constexpr int kFractionBits = 20;

uint64_t ticks_of(uint64_t ps) {  // round(ps * 2^20 / 10^6)
  return uint64_t((static_cast<unsigned __int128>(ps) << kFractionBits) / 1000000u +
                  ((static_cast<unsigned __int128>(ps) << kFractionBits) % 1000000u >= 500000u));
}

// A tick count as the shortest decimal that reads back as exactly that double.
void write_ticks(std::FILE* out, uint64_t ticks) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, std::ldexp(double(ticks), -kFractionBits));
  std::fwrite(buf, 1, size_t(r.ptr - buf), out);
}

void write_start_and_dur(std::FILE* out, uint64_t start_ps, uint64_t end_ps) {
  const uint64_t start = ticks_of(start_ps);
  write_ticks(out, start);
  std::fputs(",\"dur\":", out);
  write_ticks(out, ticks_of(end_ps) - start);
}
}  // namespace

Timeline::Timeline(TimelineOptions options) : options_(std::move(options)) {
  temporary_ = options_.file;
  temporary_ += ".tmp-" + std::to_string(::getpid());
  out_ = std::fopen(temporary_.c_str(), "wb");
  if (!out_)
    throw InputError("--timeline " + options_.file.string(),
                     std::string("cannot write the file: ") + std::strerror(errno));
  buffer_.resize(1 << 20);
  std::setvbuf(out_, buffer_.data(), _IOFBF, buffer_.size());
  std::fputs("{\"traceEvents\":[\n", out_);
}

Timeline::~Timeline() {
  if (closed_) return;
  if (out_) std::fclose(out_);
  std::error_code ec;
  std::filesystem::remove(temporary_, ec);
}

uint32_t Timeline::new_row(uint32_t track, uint32_t lane) {
  const Track& t = tracks_[track];
  rows_.push_back({t.group, track, lane, lane == 0 ? t.name : t.name + " #" + std::to_string(lane + 1)});
  return uint32_t(rows_.size());  // thread ids from 1
}

uint32_t Timeline::track(const std::string& group, const std::string& name, bool laned) {
  uint32_t g = 0;
  while (g < groups_.size() && groups_[g] != group) ++g;
  if (g == groups_.size()) groups_.push_back(group);
  tracks_.push_back(Track{g, name, laned, {}, {}});
  const uint32_t id = uint32_t(tracks_.size() - 1);
  tracks_[id].lanes.push_back(new_row(id, 0));
  tracks_[id].lane_end.push_back(0);
  return id;
}

void Timeline::span(uint32_t track, const char* name, uint64_t start_ps, uint64_t end_ps,
                    const std::string& args) {
  start_ps = std::max(start_ps, options_.from_ps);
  end_ps = std::min(end_ps, options_.to_ps);
  if (end_ps <= start_ps || capped_) return;
  Track& t = tracks_[track];
  size_t lane = 0;
  if (t.laned) {
    // The first row free at the span's start: spans come nearly in time order, and a
    // row only ever takes spans after its last one, so rows never overlap.
    while (lane < t.lanes.size() && t.lane_end[lane] > start_ps) ++lane;
    if (lane == t.lanes.size()) {
      if (lane == kMaxLanes) {
        ++lane_overflows_;
        return;
      }
      t.lanes.push_back(new_row(track, uint32_t(lane)));
      t.lane_end.push_back(0);
    }
    t.lane_end[lane] = end_ps;
  }
  if (events_ == options_.max_events) {
    capped_ = true;
    capped_at_ps_ = start_ps;
    return;
  }
  write_event(t.group, t.lanes[lane], name, start_ps, end_ps, args);
}

void Timeline::write_event(uint32_t group, uint32_t row, const char* name, uint64_t start_ps,
                           uint64_t end_ps, const std::string& args) {
  std::fprintf(out_, "%s{\"name\":\"%s\",\"ph\":\"X\",\"pid\":%u,\"tid\":%u,\"ts\":", events_ ? ",\n" : "",
               name, group + 1, row);
  write_start_and_dur(out_, start_ps, end_ps);
  if (!args.empty()) std::fprintf(out_, ",\"args\":{%s}", args.c_str());
  std::fputc('}', out_);
  ++events_;
}

void Timeline::close() {
  if (closed_) return;
  using nlohmann::json;
  // Names of the rows: processes are the groups, threads the tracks' rows, in the
  // order they were made (the viewers sort by these indexes).
  bool first = events_ == 0;
  const auto meta = [&](const json& e) {
    std::fprintf(out_, "%s%s", first ? "" : ",\n", e.dump().c_str());
    first = false;
  };
  for (uint32_t g = 0; g < groups_.size(); ++g) {
    meta({{"name", "process_name"}, {"ph", "M"}, {"pid", g + 1}, {"args", {{"name", groups_[g]}}}});
    meta({{"name", "process_sort_index"}, {"ph", "M"}, {"pid", g + 1}, {"args", {{"sort_index", g}}}});
  }
  for (uint32_t r = 0; r < rows_.size(); ++r) {
    const Row& row = rows_[r];
    const json pid = row.group + 1, tid = r + 1;
    // A track's rows together, in the order the tracks were made.
    const uint64_t order = uint64_t(row.track) * kMaxLanes + row.lane;
    meta({{"name", "thread_name"}, {"ph", "M"}, {"pid", pid}, {"tid", tid}, {"args", {{"name", row.name}}}});
    meta({{"name", "thread_sort_index"}, {"ph", "M"}, {"pid", pid}, {"tid", tid}, {"args", {{"sort_index", order}}}});
  }
  const double cycle = options_.cycle_ps;
  const auto cycles = [&](uint64_t ps) { return json(uint64_t(std::llround(double(ps) / cycle))); };
  json rtsim = {{"level", options_.level},
                {"cycle_ps", cycle},
                {"from_cycle", cycles(options_.from_ps)},
                {"to_cycle", options_.to_ps == UINT64_MAX ? json(nullptr) : cycles(options_.to_ps)},
                {"max_events", options_.max_events},
                {"events", events_},
                {"capped_at_cycle", capped_ ? cycles(capped_at_ps_) : json(nullptr)},
                {"lane_overflows", lane_overflows_}};
  std::fprintf(out_, "\n],\"displayTimeUnit\":\"ns\",\"otherData\":{\"rtsim\":%s}}\n", rtsim.dump().c_str());
  const bool write_failed = std::ferror(out_) != 0;
  const bool close_failed = std::fclose(out_) != 0;
  out_ = nullptr;
  std::error_code ec;
  if (write_failed || close_failed) {
    std::filesystem::remove(temporary_, ec);
    throw std::runtime_error(options_.file.string() + ": writing the timeline failed");
  }
  std::filesystem::rename(temporary_, options_.file, ec);
  if (ec) {
    std::filesystem::remove(temporary_, ec);
    throw std::runtime_error(options_.file.string() + ": " + ec.message());
  }
  closed_ = true;
}

}  // namespace rtsim::sim
