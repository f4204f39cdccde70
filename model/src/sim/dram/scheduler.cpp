#include <rtsim/model/sim/dram/scheduler.h>

#include <algorithm>
#include <cmath>

namespace rtsim::sim {

FrFcfsScheduler::FrFcfsScheduler(const DramConfig& config, uint32_t channels, size_t banks_per_channel)
    : channels_(channels) {
  const double queue = double(config.queue_entries);
  drain_high_ = std::max<uint32_t>(1, uint32_t(std::ceil(queue * config.write_drain_high)));
  drain_low_ = std::min<uint32_t>(uint32_t(std::floor(queue * config.write_drain_low)),
                                  drain_high_ - 1);
  for (State& s : channels_)
    for (auto* marks : {&s.active_hit_mark, &s.any_hit_mark, &s.column_mark, &s.row_mark})
      marks->assign(banks_per_channel, 0);
}

void FrFcfsScheduler::begin(uint32_t c) {
  State& s = channels_[c];
  if (++s.stamp == 0) {  // wrapped: forget all marks
    for (auto* marks : {&s.active_hit_mark, &s.any_hit_mark, &s.column_mark, &s.row_mark})
      std::fill(marks->begin(), marks->end(), 0);
    s.stamp = 1;
  }
}

void FrFcfsScheduler::update_drain_mode(State& s, const DramQueue& queue) const {
  // Reads first. Writes drain from the high watermark down to the low one; below it
  // they also go while no read waits, until one does.
  const uint32_t reads = queue.reads, writes = queue.writes;
  if (writes == 0) {
    s.draining_writes = false;
  } else if (writes >= drain_high_ && !(s.draining_writes && s.drain_to_low)) {
    s.draining_writes = true, s.drain_to_low = true;
  } else if (!s.draining_writes) {
    if (reads == 0) s.draining_writes = true, s.drain_to_low = false;
  } else if (reads > 0 && (!s.drain_to_low || writes <= drain_low_)) {
    s.draining_writes = false;
  }
}

// In the direction being served: row hits first (each bank's oldest), then row
// commands for each bank's oldest request.
void FrFcfsScheduler::offer_requests(DramDevice& device, DramDevice::Channel& ch,
                                     const DramQueue& queue, const DramRefreshManager& refresh,
                                     DramCandidate& best) {
  State& s = channels_[ch.index];
  const uint32_t stamp = s.stamp;
  const uint32_t banks = device.banks();
  update_drain_mode(s, queue);
  const bool writes = s.draining_writes;
  // Banks with a queued hit on their open row: of the serviced direction (their row
  // stays open for it), of any direction (the page policies keep the row).
  for (const DramPending& p : queue.entries) {
    const size_t b = size_t(p.where.rank) * banks + p.where.bank;
    if (ch.banks[b].open_row != int64_t(p.where.row)) continue;
    s.any_hit_mark[b] = stamp;
    if (p.request.write == writes) s.active_hit_mark[b] = stamp;
  }
  for (size_t i = 0; i < queue.entries.size(); ++i) {
    const DramPending& p = queue.entries[i];
    const uint32_t r = p.where.rank, bank = p.where.bank;
    const size_t b = size_t(r) * banks + bank;
    if (p.request.write != writes) {
      // A row activated for a request of the other direction is finished first: its
      // column command goes (the bus turns for it) rather than the row being closed
      // unused by the direction now served, which would cost the activate again.
      const DramDevice::Bank& k = ch.banks[b];
      if (k.opened_for != int8_t(p.request.write) || k.open_row != int64_t(p.where.row) ||
          s.column_mark[b] == stamp)
        continue;
      s.column_mark[b] = stamp;
      DramCandidate c;
      c.age = i, c.rank = r, c.bank = bank;
      c.time_ps = device.earliest_column(ch, r, bank, p.request.write, p.ready_ps);
      if (c.time_ps >= refresh.due(ch.index, r)) continue;
      c.priority = 1, c.action = DramCandidate::Action::Column;
      keep_best(best, c);
      continue;
    }
    const uint64_t due = refresh.due(ch.index, r);  // nothing new for the rank from then
    DramCandidate c;
    c.age = i, c.rank = r, c.bank = bank;
    if (ch.banks[b].open_row == int64_t(p.where.row)) {
      if (s.column_mark[b] == stamp) continue;  // an older hit to this bank goes first
      s.column_mark[b] = stamp;
      c.time_ps = device.earliest_column(ch, r, bank, p.request.write, p.ready_ps);
      if (c.time_ps >= due) continue;
      c.priority = 1, c.action = DramCandidate::Action::Column;
    } else {
      if (s.row_mark[b] == stamp) continue;  // row commands serve the bank's oldest
      s.row_mark[b] = stamp;
      if (s.active_hit_mark[b] == stamp) continue;  // hits first
      if (ch.banks[b].opened_for == int8_t(!writes)) continue;  // committed to the other direction
      if (ch.banks[b].open_row >= 0) {
        c.time_ps = device.earliest_precharge(ch, r, bank, p.ready_ps);
        c.action = DramCandidate::Action::Precharge, c.conflict = true;
      } else {
        c.time_ps = device.earliest_activate(ch, r, bank, p.ready_ps);
        if (c.time_ps >= due) continue;
        c.action = DramCandidate::Action::Activate;
      }
      c.priority = 2;
    }
    keep_best(best, c);
  }
}


}  // namespace rtsim::sim
