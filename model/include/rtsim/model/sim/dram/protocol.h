#pragma once
// What the DRAM's parts (dram.h) say to each other and to their callers: requests and
// their completions, the device's commands, and a candidate command with the order in
// which the controller prefers candidates.
#include <rtsim/model/sim/dram/address_map.h>

#include <cstddef>
#include <cstdint>
#include <string>

namespace rtsim::sim {

enum class RowOutcome : uint8_t { Hit = 0, Closed = 1, Conflict = 2 };
enum class PagePolicy : uint8_t { Open, Closed, Timeout };
PagePolicy parse_page_policy(const std::string& name);  // throws InputError naming dram.page_policy

struct DramRequest {
  uint64_t address = 0;
  // When the requester FIRST tried to send it; earlier than the enqueue time when a
  // full queue held it back. Latency is measured from here.
  uint64_t arrival_ps = 0;
  uint64_t tag = 0;  // the caller's id, returned with the completion
  bool write = false;
};

struct DramCompletion {
  uint64_t tag = 0;
  uint64_t done_ps = 0;  // last data beat on the bus (reads: delivered, writes: written)
  RowOutcome outcome = RowOutcome::Hit;
  bool write = false;
};

// One request as it reaches the DRAM, for request traces (memory_trace.h).
struct DramRequestRecord {
  uint64_t time_ps = 0;  // when the requester first tried to send it (functional level: 0)
  uint64_t address = 0;
  bool write = false;
  DramAddress where;  // the address map's decode of it
};

enum class DramCommandKind : uint8_t { Activate, Precharge, Read, Write, Refresh };
const char* dram_command_name(DramCommandKind kind);  // "ACT", "PRE", "RD", "WR", "REF"

// One command as the device sees it. Refresh is per rank (bank_group, bank, row 0).
// Commands reach the observer when decided. On the queued path that is time order per
// channel, except that an auto-precharge (closed page policy, not on the command bus)
// is reported with its column command while carrying its own, later, time; the lt
// path places commands ahead, so sort by time to replay a log.
struct DramCommand {
  DramCommandKind kind = DramCommandKind::Activate;
  uint64_t time_ps = 0;
  uint32_t channel = 0, rank = 0, bank_group = 0, bank = 0;  // bank within the rank
  uint64_t row = 0;
};

// A command one of the parts proposes (the scheduler for a queued request, the refresh
// manager, the page policy) and the time the device allows it.
struct DramCandidate {
  enum class Action : uint8_t { Column, Activate, Precharge, Refresh };
  uint64_t time_ps = UINT64_MAX;  // UINT64_MAX: no candidate
  uint8_t priority = 255;  // lower first among commands legal at the same edge
  size_t age = SIZE_MAX;   // queue position of its request
  Action action = Action::Column;
  uint32_t rank = 0, bank = 0;  // bank within the rank
  bool conflict = false;        // a precharge for a request needing another row
};

// The controller issues the candidate legal earliest; at one edge the lower priority,
// then the older request.
inline void keep_best(DramCandidate& best, const DramCandidate& c) {
  if (c.time_ps < best.time_ps ||
      (c.time_ps == best.time_ps &&
       (c.priority < best.priority || (c.priority == best.priority && c.age < best.age))))
    best = c;
}

}  // namespace rtsim::sim
