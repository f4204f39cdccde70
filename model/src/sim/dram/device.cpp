#include <rtsim/model/sim/dram/device.h>

#include <algorithm>
#include <iterator>

namespace rtsim::sim {

DramTimings::DramTimings(const DramConfig& config, uint32_t access_bytes) {
  banks_per_group = std::max<uint32_t>(1, config.banks / std::max<uint32_t>(1, config.bank_groups));
  bursts = std::max<uint32_t>(1, (access_bytes + config.burst_bytes - 1) / config.burst_bytes);
  tck = config.tck_ps;
  transfer = uint64_t(bursts) * config.burst_cycles * tck;
  cl = config.tcl * tck, cwl = config.tcwl * tck;
  rcd = config.trcd * tck, rcd_write = config.trcd_write * tck;
  rp = config.trp * tck, ras = config.tras * tck;
  rrd_s = config.trrd_s * tck, rrd_l = config.trrd_l * tck, faw = config.tfaw * tck;
  // One access is `bursts` column bursts back to back; its bank group's column path
  // is busy for all of them.
  column_s = uint64_t(bursts) * config.tccd_s * tck;
  column_l = uint64_t(bursts) * config.tccd_l * tck;
  // tRTP counts from the access's last burst.
  read_to_pre = (uint64_t(bursts - 1) * config.tccd_l + config.trtp) * tck;
  write_to_pre = cwl + transfer + config.twr * tck;
  write_to_read_s = cwl + transfer + config.twtr_s * tck;
  write_to_read_l = cwl + transfer + config.twtr_l * tck;
  rtrs = config.trtrs * tck;
  refi = uint64_t(config.trefi) * tck, rfc = uint64_t(config.trfc) * tck;
  page_timeout = uint64_t(config.page_timeout) * tck;
}

DramDevice::DramDevice(const DramConfig& config, uint32_t access_bytes, DramCounters& counters)
    : t_(config, access_bytes), ranks_(config.ranks), banks_(config.banks),
      bank_groups_(std::max<uint32_t>(1, config.bank_groups)), channels_(config.channels),
      counters_(&counters) {
  for (uint32_t i = 0; i < config.channels; ++i) {
    Channel& ch = channels_[i];
    ch.index = i;
    ch.banks.resize(size_t(ranks_) * banks_);
    ch.groups.resize(size_t(ranks_) * bank_groups_);
    ch.ranks.resize(ranks_);
  }
}

// ------------------------------------------------------------- timing rules

uint64_t DramDevice::activate_fit(const Rank& r, uint32_t group, uint64_t t) const {
  // Move t until it keeps tRRD_S/L to every placed activate of the rank and no four
  // placed activates lie with it in one tFAW window (five consecutive span >= tFAW).
  const auto& acts = r.lt_acts;
  const uint64_t reach = std::max({t_.rrd_l, t_.rrd_s, t_.faw});
  for (bool moved = true; moved;) {
    moved = false;
    // Only activates within tFAW (the longest of these spacings) of t can clash.
    const auto lo = std::lower_bound(acts.begin(), acts.end(),
                                     std::make_pair(t > reach ? t - reach : 0, 0u));
    for (auto it = lo; it != acts.end() && it->first < t + reach; ++it) {
      const uint64_t a = it->first;
      const uint64_t rrd = it->second == group ? t_.rrd_l : t_.rrd_s;
      if (t < a + rrd && t + rrd > a) {
        t = t_.edge(a + rrd);
        moved = true;
        break;
      }
    }
    if (moved) continue;
    const size_t at = size_t(std::lower_bound(acts.begin(), acts.end(), std::make_pair(t, 0u)) - acts.begin());
    // The five-activate windows holding t: four placed ones around it, t among them.
    for (size_t k = 0; k < 5 && !moved; ++k) {
      if (at + k < 4 || at + k > acts.size()) continue;
      const size_t first = at + k - 4;  // the window's first placed activate
      const size_t last = first + 3;    // its last placed one (t makes five)
      const uint64_t lo_t = std::min(acts[first].first, t), hi_t = std::max(acts[last].first, t);
      if (hi_t - lo_t < t_.faw) {
        t = t_.edge(acts[first].first + t_.faw);
        moved = true;
      }
    }
  }
  return t;
}

uint64_t DramDevice::earliest_activate(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t) {
  const Rank& r = ch.ranks[rank];
  if (ahead_) {
    // Placed among the rank's activates, not only after the latest (other banks' rows
    // open in parallel, as a reordering controller opens them).
    t = std::max({t, bank_state(ch, rank, bank).act_ready_ps, r.refresh_end_ps});
    for (;;) {
      const uint64_t fit = activate_fit(r, bank / t_.banks_per_group, t);
      const uint64_t slot = command_slot(ch, fit);
      if (slot == fit) return slot;
      t = slot;
    }
  }
  t = std::max({t, bank_state(ch, rank, bank).act_ready_ps, r.activate_ready_ps,
                group_of(ch, rank, bank).activate_ready_ps, r.refresh_end_ps});
  if (r.acts_seen == 4) t = std::max(t, r.recent_acts_ps[r.oldest_act] + t_.faw);
  return command_slot(ch, t);
}

uint64_t DramDevice::earliest_precharge(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t) {
  return command_slot(ch, std::max(t, bank_state(ch, rank, bank).pre_ready_ps));
}

uint64_t DramDevice::column_fit(const Channel& ch, uint32_t rank, uint32_t group, bool write,
                                  uint64_t t) const {
  // Move t past every placed column it would clash with, until none does. Spacing
  // between a column at a (data [a+lat_a, +tBURST)) and one at b > a:
  //   data bus:  b + lat_b >= a + lat_a + tBURST (+ tRTRS on a change of direction or rank)
  //   tCCD:      b >= a + tCCD_S (same rank), tCCD_L (same group)
  //   tWTR:      b >= a + tWTR_S/L when a writes and b reads (same rank / group)
  const auto spacing = [&](uint64_t lat_a, bool write_a, uint32_t rank_a, uint32_t group_a,
                           uint64_t lat_b, bool write_b, uint32_t rank_b, uint32_t group_b) {
    const bool turn = write_a != write_b || rank_a != rank_b;
    int64_t need = int64_t(lat_a + t_.transfer + (turn ? t_.rtrs : 0)) - int64_t(lat_b);
    if (rank_a == rank_b) {
      const bool same_group = group_a == group_b;
      need = std::max<int64_t>(need, int64_t(same_group ? t_.column_l : t_.column_s));
      if (write_a && !write_b)
        need = std::max<int64_t>(need, int64_t(same_group ? t_.write_to_read_l : t_.write_to_read_s));
    }
    return need;
  };
  const uint64_t lat = write ? t_.cwl : t_.cl;
  // Only columns this close can clash (the largest spacing in either order).
  const uint64_t reach = std::max(t_.cl, t_.cwl) + t_.transfer + t_.rtrs + t_.column_l + t_.write_to_read_l;
  const auto& uses = ch.lt_columns;
  for (bool moved = true; moved;) {
    moved = false;
    const auto lo = std::lower_bound(uses.begin(), uses.end(), t > reach ? t - reach : 0,
                                     [](const ColumnUse& u, uint64_t x) { return u.time_ps < x; });
    for (auto it = lo; it != uses.end() && it->time_ps < t + reach; ++it) {
      const ColumnUse& u = *it;
      const uint64_t lat_u = u.write ? t_.cwl : t_.cl;
      const int64_t after = spacing(lat_u, u.write, u.rank, u.group, lat, write, rank, group);
      const int64_t before = spacing(lat, write, rank, group, lat_u, u.write, u.rank, u.group);
      // Clash when t lies in (u - before, u + after): neither order fits.
      if (int64_t(t) < int64_t(u.time_ps) + after && int64_t(t) + before > int64_t(u.time_ps)) {
        t = t_.edge(uint64_t(int64_t(u.time_ps) + after));
        moved = true;
        break;
      }
    }
  }
  return t;
}

uint64_t DramDevice::earliest_column(Channel& ch, uint32_t rank, uint32_t bank, bool write,
                                    uint64_t t) {
  const Bank& k = bank_state(ch, rank, bank);
  const Group& g = group_of(ch, rank, bank);
  const Rank& r = ch.ranks[rank];
  if (ahead_) {
    // Placed among the other banks' columns, not only after them.
    t = std::max(t, write ? k.write_ready_ps : k.read_ready_ps);
    const uint32_t group = bank / t_.banks_per_group;
    for (;;) {
      const uint64_t fit = column_fit(ch, rank, group, write, t);
      const uint64_t slot = command_slot(ch, fit);
      if (slot == fit) return slot;
      t = slot;
    }
  }
  t = std::max({t, write ? k.write_ready_ps : k.read_ready_ps, r.column_ready_ps,
                g.column_ready_ps});
  if (!write) t = std::max({t, r.read_after_write_ps, g.read_after_write_ps});
  if (ch.bus_used) {
    // Data may not overlap the previous burst; a change of direction or rank idles
    // the bus tRTRS (read to write = tCL + tBURST - tCWL + tRTRS, as DRAMsim3 has it).
    const bool turn = ch.bus_last_write != write || ch.bus_last_rank != rank;
    const uint64_t data_from = ch.bus_free_ps + (turn ? t_.rtrs : 0);
    const uint64_t latency = write ? t_.cwl : t_.cl;
    if (t + latency < data_from) t = t_.edge(data_from - latency);
  }
  return command_slot(ch, t);
}

uint64_t DramDevice::earliest_refresh(Channel& ch, uint32_t rank, uint64_t t) {
  const Rank& r = ch.ranks[rank];
  t = std::max(t, r.refresh_end_ps);
  for (uint32_t b = 0; b < banks_; ++b) t = std::max(t, bank_state(ch, rank, b).act_ready_ps);
  return command_slot(ch, t);
}

uint64_t DramDevice::command_slot(const Channel& ch, uint64_t t) const {
  if (!ahead_) return std::max(t, ch.command_free_ps);
  // Loosely timed: commands are placed ahead of time, so later requests' row commands
  // may take free slots before earlier requests' column commands.
  auto it = std::lower_bound(ch.reserved_slots.begin(), ch.reserved_slots.end(), t);
  while (it != ch.reserved_slots.end() && *it == t) t += t_.tck, ++it;
  return t;
}

void DramDevice::take_command_slot(Channel& ch, uint64_t t) {
  if (!ahead_) {
    ch.command_free_ps = t + t_.tck;
    return;
  }
  ch.reserved_slots.insert(
      std::lower_bound(ch.reserved_slots.begin(), ch.reserved_slots.end(), t), t);
}

void DramDevice::emit(DramCommandKind kind, uint64_t t, const Channel& ch, uint32_t rank,
                     uint32_t bank, uint64_t row) {
  if (!observer_) return;
  DramCommand c;
  c.kind = kind, c.time_ps = t, c.channel = ch.index, c.rank = rank;
  c.bank_group = bank / t_.banks_per_group, c.bank = bank, c.row = row;
  observer_(c);
}

void DramDevice::activate(Channel& ch, uint32_t rank, uint32_t bank, uint64_t row, uint64_t t) {
  Bank& k = bank_state(ch, rank, bank);
  Rank& r = ch.ranks[rank];
  k.open_row = int64_t(row);
  k.read_ready_ps = t + t_.rcd;
  k.write_ready_ps = t + t_.rcd_write;
  k.pre_ready_ps = t + t_.ras;
  k.last_use_ps = t;
  r.activate_ready_ps = t + t_.rrd_s;
  group_of(ch, rank, bank).activate_ready_ps = t + t_.rrd_l;
  r.recent_acts_ps[r.oldest_act] = t;
  r.oldest_act = (r.oldest_act + 1) % 4;
  r.acts_seen = std::min<uint32_t>(4, r.acts_seen + 1);
  if (ahead_) {
    const std::pair<uint64_t, uint32_t> act{t, bank / t_.banks_per_group};
    r.lt_acts.insert(std::lower_bound(r.lt_acts.begin(), r.lt_acts.end(), act), act);
  }
  take_command_slot(ch, t);
  ++counters_->activates;
  emit(DramCommandKind::Activate, t, ch, rank, bank, row);
}

void DramDevice::precharge(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t,
                          bool command_bus) {
  Bank& k = bank_state(ch, rank, bank);
  const uint64_t row = uint64_t(k.open_row);
  k.open_row = -1;
  k.opened_for = -1;
  k.auto_close_after_ps = UINT64_MAX;
  k.act_ready_ps = t + t_.rp;
  if (command_bus) take_command_slot(ch, t);
  ++counters_->precharges;
  emit(DramCommandKind::Precharge, t, ch, rank, bank, row);
}

uint64_t DramDevice::column(Channel& ch, uint32_t rank, uint32_t bank, bool write, uint64_t t) {
  Bank& k = bank_state(ch, rank, bank);
  Group& g = group_of(ch, rank, bank);
  Rank& r = ch.ranks[rank];
  const uint64_t done = t + (write ? t_.cwl : t_.cl) + t_.transfer;
  if (ahead_) {
    auto& uses = ch.lt_columns;
    const auto at = std::lower_bound(uses.begin(), uses.end(), t,
                                     [](const ColumnUse& u, uint64_t x) { return u.time_ps < x; });
    if (at != uses.begin() && std::prev(at)->write != write) ++counters_->turnarounds;
    uses.insert(at, ColumnUse{t, rank, bank / t_.banks_per_group, write});
  } else if (ch.bus_used && ch.bus_last_write != write) {
    ++counters_->turnarounds;
  }
  ch.bus_free_ps = std::max(ch.bus_free_ps, done);
  ch.bus_used = true, ch.bus_last_write = write, ch.bus_last_rank = rank;
  counters_->bus_busy_ps += t_.transfer;
  r.column_ready_ps = t + t_.column_s;
  g.column_ready_ps = t + t_.column_l;
  if (write) {
    r.read_after_write_ps = std::max(r.read_after_write_ps, t + t_.write_to_read_s);
    g.read_after_write_ps = std::max(g.read_after_write_ps, t + t_.write_to_read_l);
    k.pre_ready_ps = std::max(k.pre_ready_ps, t + t_.write_to_pre);
  } else {
    k.pre_ready_ps = std::max(k.pre_ready_ps, t + t_.read_to_pre);
  }
  k.last_use_ps = t;
  take_command_slot(ch, t);
  emit(write ? DramCommandKind::Write : DramCommandKind::Read, t, ch, rank, bank,
       uint64_t(k.open_row));
  return done;
}

void DramDevice::refresh(Channel& ch, uint32_t rank, uint64_t t) {
  Rank& r = ch.ranks[rank];
  r.refresh_end_ps = t + t_.rfc;
  take_command_slot(ch, t);
  ++counters_->refreshes;
  emit(DramCommandKind::Refresh, t, ch, rank, 0, 0);
}

void DramDevice::forget_before(Channel& ch, uint64_t oldest) {
  auto& slots = ch.reserved_slots;
  slots.erase(slots.begin(), std::lower_bound(slots.begin(), slots.end(), oldest));
  auto& uses = ch.lt_columns;
  uses.erase(uses.begin(), std::lower_bound(uses.begin(), uses.end(), oldest,
                                            [](const ColumnUse& u, uint64_t x) { return u.time_ps < x; }));
  for (Rank& rank : ch.ranks) {
    auto& acts = rank.lt_acts;
    acts.erase(acts.begin(), std::lower_bound(acts.begin(), acts.end(), std::make_pair(oldest, 0u)));
  }
}

}  // namespace rtsim::sim
