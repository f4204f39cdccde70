#include <rtsim/model/sim/dram.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace rtsim::sim {

namespace {
// lt: how far before the latest arrival a request may still be placed at its own time.
constexpr uint64_t kLtHorizonPs = 4'000'000;
}  // namespace

namespace {
uint32_t log2_exact(uint64_t v) {
  uint32_t bits = 0;
  while ((uint64_t(1) << bits) < v) ++bits;
  return bits;
}
constexpr size_t kHistogramBuckets = 16384;  // 1 ns each
}  // namespace

PagePolicy parse_page_policy(const std::string& name) {
  if (name == "open") return PagePolicy::Open;
  if (name == "closed") return PagePolicy::Closed;
  if (name == "timeout") return PagePolicy::Timeout;
  throw InputError("dram.page_policy", "unknown policy '" + name + "' (open | closed | timeout)");
}

const char* dram_command_name(DramCommandKind kind) {
  switch (kind) {
    case DramCommandKind::Activate: return "ACT";
    case DramCommandKind::Precharge: return "PRE";
    case DramCommandKind::Read: return "RD";
    case DramCommandKind::Write: return "WR";
    case DramCommandKind::Refresh: return "REF";
  }
  return "?";
}

// ------------------------------------------------------------------ address map

std::vector<std::string> dram_mapping_fields(const std::string& mapping) {
  std::vector<std::string> names;
  std::stringstream in(mapping);
  for (std::string field; std::getline(in, field, ':');) names.push_back(field);
  return names;
}

uint32_t dram_field_bits(uint64_t values) {
  uint32_t bits = 0;
  while ((uint64_t(1) << bits) < values) ++bits;
  return bits;
}

DramAddressMap::DramAddressMap(const DramConfig& c, uint32_t access_bytes) {
  offset_bits_ = log2_exact(access_bytes);
  const uint32_t groups = std::max<uint32_t>(1, c.bank_groups);
  banks_per_group_ = std::max<uint32_t>(1, c.banks / groups);
  const std::vector<std::string> names = dram_mapping_fields(c.address_mapping);
  group_field_ = std::find(names.begin(), names.end(), "bankgroup") != names.end();
  // Least significant first: the last name sits right above the access offset.
  // Each field is a digit of a mixed-radix number, so a channel count need not be a
  // power of two (12 GDDR6 channels of a 192-bit bus); for powers of two the digits
  // are the bit fields a controller's mapping names.
  for (auto it = names.rbegin(); it != names.rend(); ++it) {
    Field f{};
    if (*it == "row") f.which = Row, f.radix = it + 1 == names.rend() ? 0 : (uint64_t(1) << 24);
    else if (*it == "rank") f.which = Rank, f.radix = c.ranks;
    else if (*it == "bank") f.which = Bank, f.radix = group_field_ ? banks_per_group_ : c.banks;
    else if (*it == "bankgroup") f.which = BankGroup, f.radix = groups;
    else if (*it == "column") f.which = Column, f.radix = std::max<uint64_t>(1, c.row_bytes / access_bytes);
    else if (*it == "channel") f.which = Channel, f.radix = c.channels;
    else throw InputError("dram.address_mapping", "unknown field '" + *it + "'");
    // A row field below other fields gets a fixed range (2^24 rows) so the fields above
    // have room; row numbers then wrap, which only matters for images above 2^40 bytes.
    // A row on top (radix 0) takes whatever is left.
    fields_.push_back(f);
  }
}

DramAddress DramAddressMap::decode(uint64_t address) const {
  DramAddress out;
  uint32_t bank_field = 0, group_field = 0;
  uint64_t rest = address >> offset_bits_;
  for (const Field& f : fields_) {
    uint64_t value = rest;
    if (f.radix != 0) value = rest % f.radix, rest /= f.radix;
    else rest = 0;
    switch (f.which) {
      case Row: out.row = value; break;
      case Rank: out.rank = uint32_t(value); break;
      case Bank: bank_field = uint32_t(value); break;
      case BankGroup: group_field = uint32_t(value); break;
      case Column: out.column = uint32_t(value); break;
      case Channel: out.channel = uint32_t(value); break;
    }
  }
  out.bank = group_field_ ? group_field * banks_per_group_ + bank_field : bank_field;
  out.bank_group = out.bank / banks_per_group_;
  return out;
}

// ------------------------------------------------------------------------ model

DramModel::DramModel(const DramConfig& config, uint32_t access_bytes)
    : config_(config), map_(config, access_bytes), policy_(parse_page_policy(config.page_policy)),
      access_bytes_(access_bytes), tck_(config.tck_ps), channels_(config.channels),
      read_histogram_ns_(kHistogramBuckets + 1, 0), write_histogram_ns_(kHistogramBuckets + 1, 0) {
  config_.bank_groups = std::max<uint32_t>(1, config_.bank_groups);
  banks_per_group_ = std::max<uint32_t>(1, config_.banks / config_.bank_groups);
  bursts_ = std::max<uint32_t>(1, (access_bytes + config.burst_bytes - 1) / config.burst_bytes);
  const uint64_t tck = tck_;
  transfer_ps_ = uint64_t(bursts_) * config.burst_cycles * tck;
  cl_ = config.tcl * tck, cwl_ = config.tcwl * tck;
  rcd_ = config.trcd * tck, rcd_write_ = config.trcd_write * tck;
  rp_ = config.trp * tck, ras_ = config.tras * tck;
  rrd_s_ = config.trrd_s * tck, rrd_l_ = config.trrd_l * tck, faw_ = config.tfaw * tck;
  // One access is `bursts_` column bursts back to back; its bank group's column path
  // is busy for all of them.
  column_s_ = uint64_t(bursts_) * config.tccd_s * tck;
  column_l_ = uint64_t(bursts_) * config.tccd_l * tck;
  // tRTP counts from the access's last burst.
  read_to_pre_ = (uint64_t(bursts_ - 1) * config.tccd_l + config.trtp) * tck;
  write_to_pre_ = cwl_ + transfer_ps_ + config.twr * tck;
  write_to_read_s_ = cwl_ + transfer_ps_ + config.twtr_s * tck;
  write_to_read_l_ = cwl_ + transfer_ps_ + config.twtr_l * tck;
  rtrs_ = config.trtrs * tck;
  refi_ = uint64_t(config.trefi) * tck, rfc_ = uint64_t(config.trfc) * tck;
  page_timeout_ = uint64_t(config.page_timeout) * tck;
  const double queue = double(config.queue_entries);
  drain_high_ = std::max<uint32_t>(1, uint32_t(std::ceil(queue * config.write_drain_high)));
  drain_low_ = std::min<uint32_t>(uint32_t(std::floor(queue * config.write_drain_low)),
                                  drain_high_ - 1);
  const size_t banks = size_t(config.ranks) * config.banks;
  for (uint32_t i = 0; i < config.channels; ++i) {
    Channel& ch = channels_[i];
    ch.index = i;
    ch.banks.resize(banks);
    ch.groups.resize(size_t(config.ranks) * config_.bank_groups);
    ch.ranks.resize(config.ranks);
    // Ranks refresh staggered over the interval, so a channel never loses all at once.
    for (uint32_t r = 0; r < config.ranks; ++r)
      ch.ranks[r].refresh_due_ps = refi_ ? edge(refi_ * (r + 1) / config.ranks) : UINT64_MAX;
    ch.queue.reserve(config.queue_entries);
    ch.active_hit_mark.assign(banks, 0);
    ch.any_hit_mark.assign(banks, 0);
    ch.column_mark.assign(banks, 0);
    ch.row_mark.assign(banks, 0);
  }
}

uint64_t DramModel::latency_ps(RowOutcome outcome) const {
  switch (outcome) {
    case RowOutcome::Hit: return cl_ + transfer_ps_;
    case RowOutcome::Closed: return rcd_ + cl_ + transfer_ps_;
    case RowOutcome::Conflict: return rp_ + rcd_ + cl_ + transfer_ps_;
  }
  return 0;
}

double DramModel::peak_bytes_per_second() const {
  return double(config_.channels) * access_bytes_ / (double(transfer_ps_) * 1e-12);
}

// ------------------------------------------------------------- timing rules

uint64_t DramModel::lt_activate_fit(const Rank& r, uint32_t group, uint64_t t) const {
  // Move t until it keeps tRRD_S/L to every placed activate of the rank and no four
  // placed activates lie with it in one tFAW window (five consecutive span >= tFAW).
  const auto& acts = r.lt_acts;
  const uint64_t reach = std::max({rrd_l_, rrd_s_, faw_});
  for (bool moved = true; moved;) {
    moved = false;
    // Only activates within tFAW (the longest of these spacings) of t can clash.
    const auto lo = std::lower_bound(acts.begin(), acts.end(),
                                     std::make_pair(t > reach ? t - reach : 0, 0u));
    for (auto it = lo; it != acts.end() && it->first < t + reach; ++it) {
      const uint64_t a = it->first;
      const uint64_t rrd = it->second == group ? rrd_l_ : rrd_s_;
      if (t < a + rrd && t + rrd > a) {
        t = edge(a + rrd);
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
      if (hi_t - lo_t < faw_) {
        t = edge(acts[first].first + faw_);
        moved = true;
      }
    }
  }
  return t;
}

uint64_t DramModel::earliest_activate(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t) {
  const Rank& r = ch.ranks[rank];
  if (lt_) {
    // Placed among the rank's activates, not only after the latest (other banks' rows
    // open in parallel, as a reordering controller opens them).
    t = std::max({t, bank_of(ch, rank, bank).act_ready_ps, r.refresh_end_ps});
    for (;;) {
      const uint64_t fit = lt_activate_fit(r, bank / banks_per_group_, t);
      const uint64_t slot = command_slot(ch, fit);
      if (slot == fit) return slot;
      t = slot;
    }
  }
  t = std::max({t, bank_of(ch, rank, bank).act_ready_ps, r.activate_ready_ps,
                group_of(ch, rank, bank).activate_ready_ps, r.refresh_end_ps});
  if (r.acts_seen == 4) t = std::max(t, r.recent_acts_ps[r.oldest_act] + faw_);
  return command_slot(ch, t);
}

uint64_t DramModel::earliest_precharge(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t) {
  return command_slot(ch, std::max(t, bank_of(ch, rank, bank).pre_ready_ps));
}

uint64_t DramModel::lt_column_fit(const Channel& ch, uint32_t rank, uint32_t group, bool write,
                                  uint64_t t) const {
  // Move t past every placed column it would clash with, until none does. Spacing
  // between a column at a (data [a+lat_a, +tBURST)) and one at b > a:
  //   data bus:  b + lat_b >= a + lat_a + tBURST (+ tRTRS on a change of direction or rank)
  //   tCCD:      b >= a + tCCD_S (same rank), tCCD_L (same group)
  //   tWTR:      b >= a + tWTR_S/L when a writes and b reads (same rank / group)
  const auto spacing = [&](uint64_t lat_a, bool write_a, uint32_t rank_a, uint32_t group_a,
                           uint64_t lat_b, bool write_b, uint32_t rank_b, uint32_t group_b) {
    const bool turn = write_a != write_b || rank_a != rank_b;
    int64_t need = int64_t(lat_a + transfer_ps_ + (turn ? rtrs_ : 0)) - int64_t(lat_b);
    if (rank_a == rank_b) {
      const bool same_group = group_a == group_b;
      need = std::max<int64_t>(need, int64_t(same_group ? column_l_ : column_s_));
      if (write_a && !write_b)
        need = std::max<int64_t>(need, int64_t(same_group ? write_to_read_l_ : write_to_read_s_));
    }
    return need;
  };
  const uint64_t lat = write ? cwl_ : cl_;
  // Only columns this close can clash (the largest spacing in either order).
  const uint64_t reach = std::max(cl_, cwl_) + transfer_ps_ + rtrs_ + column_l_ + write_to_read_l_;
  const auto& uses = ch.lt_columns;
  for (bool moved = true; moved;) {
    moved = false;
    const auto lo = std::lower_bound(uses.begin(), uses.end(), t > reach ? t - reach : 0,
                                     [](const Channel::ColumnUse& u, uint64_t x) { return u.time_ps < x; });
    for (auto it = lo; it != uses.end() && it->time_ps < t + reach; ++it) {
      const Channel::ColumnUse& u = *it;
      const uint64_t lat_u = u.write ? cwl_ : cl_;
      const int64_t after = spacing(lat_u, u.write, u.rank, u.group, lat, write, rank, group);
      const int64_t before = spacing(lat, write, rank, group, lat_u, u.write, u.rank, u.group);
      // Clash when t lies in (u - before, u + after): neither order fits.
      if (int64_t(t) < int64_t(u.time_ps) + after && int64_t(t) + before > int64_t(u.time_ps)) {
        t = edge(uint64_t(int64_t(u.time_ps) + after));
        moved = true;
        break;
      }
    }
  }
  return t;
}

uint64_t DramModel::earliest_column(Channel& ch, uint32_t rank, uint32_t bank, bool write,
                                    uint64_t t) {
  const Bank& k = bank_of(ch, rank, bank);
  const Group& g = group_of(ch, rank, bank);
  const Rank& r = ch.ranks[rank];
  if (lt_) {
    // Placed among the other banks' columns, not only after them.
    t = std::max(t, write ? k.write_ready_ps : k.read_ready_ps);
    const uint32_t group = bank / banks_per_group_;
    for (;;) {
      const uint64_t fit = lt_column_fit(ch, rank, group, write, t);
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
    const uint64_t data_from = ch.bus_free_ps + (turn ? rtrs_ : 0);
    const uint64_t latency = write ? cwl_ : cl_;
    if (t + latency < data_from) t = edge(data_from - latency);
  }
  return command_slot(ch, t);
}

uint64_t DramModel::earliest_refresh(Channel& ch, uint32_t rank, uint64_t t) {
  const Rank& r = ch.ranks[rank];
  t = std::max({t, r.refresh_due_ps, r.refresh_end_ps});
  for (uint32_t b = 0; b < config_.banks; ++b) t = std::max(t, bank_of(ch, rank, b).act_ready_ps);
  return command_slot(ch, t);
}

uint64_t DramModel::command_slot(const Channel& ch, uint64_t t) const {
  if (!lt_) return std::max(t, ch.command_free_ps);
  // Loosely timed: commands are placed ahead of time, so later requests' row commands
  // may take free slots before earlier requests' column commands.
  auto it = std::lower_bound(ch.reserved_slots.begin(), ch.reserved_slots.end(), t);
  while (it != ch.reserved_slots.end() && *it == t) t += tck_, ++it;
  return t;
}

void DramModel::take_command_slot(Channel& ch, uint64_t t) {
  if (!lt_) {
    ch.command_free_ps = t + tck_;
    return;
  }
  ch.reserved_slots.insert(
      std::lower_bound(ch.reserved_slots.begin(), ch.reserved_slots.end(), t), t);
}

void DramModel::emit(DramCommandKind kind, uint64_t t, const Channel& ch, uint32_t rank,
                     uint32_t bank, uint64_t row) {
  if (!observer_) return;
  DramCommand c;
  c.kind = kind, c.time_ps = t, c.channel = ch.index, c.rank = rank;
  c.bank_group = bank / banks_per_group_, c.bank = bank, c.row = row;
  observer_(c);
}

void DramModel::activate(Channel& ch, uint32_t rank, uint32_t bank, uint64_t row, uint64_t t) {
  Bank& k = bank_of(ch, rank, bank);
  Rank& r = ch.ranks[rank];
  k.open_row = int64_t(row);
  k.read_ready_ps = t + rcd_;
  k.write_ready_ps = t + rcd_write_;
  k.pre_ready_ps = t + ras_;
  k.last_use_ps = t;
  r.activate_ready_ps = t + rrd_s_;
  group_of(ch, rank, bank).activate_ready_ps = t + rrd_l_;
  r.recent_acts_ps[r.oldest_act] = t;
  r.oldest_act = (r.oldest_act + 1) % 4;
  r.acts_seen = std::min<uint32_t>(4, r.acts_seen + 1);
  if (lt_) {
    const std::pair<uint64_t, uint32_t> act{t, bank / banks_per_group_};
    r.lt_acts.insert(std::lower_bound(r.lt_acts.begin(), r.lt_acts.end(), act), act);
  }
  take_command_slot(ch, t);
  ++counters_.activates;
  emit(DramCommandKind::Activate, t, ch, rank, bank, row);
}

void DramModel::precharge(Channel& ch, uint32_t rank, uint32_t bank, uint64_t t,
                          bool command_bus) {
  Bank& k = bank_of(ch, rank, bank);
  const uint64_t row = uint64_t(k.open_row);
  k.open_row = -1;
  k.opened_for = -1;
  k.auto_close_after_ps = UINT64_MAX;
  k.act_ready_ps = t + rp_;
  if (command_bus) take_command_slot(ch, t);
  ++counters_.precharges;
  emit(DramCommandKind::Precharge, t, ch, rank, bank, row);
}

uint64_t DramModel::column(Channel& ch, uint32_t rank, uint32_t bank, bool write, uint64_t t) {
  Bank& k = bank_of(ch, rank, bank);
  Group& g = group_of(ch, rank, bank);
  Rank& r = ch.ranks[rank];
  const uint64_t done = t + (write ? cwl_ : cl_) + transfer_ps_;
  if (lt_) {
    auto& uses = ch.lt_columns;
    const auto at = std::lower_bound(uses.begin(), uses.end(), t,
                                     [](const Channel::ColumnUse& u, uint64_t x) { return u.time_ps < x; });
    if (at != uses.begin() && std::prev(at)->write != write) ++counters_.turnarounds;
    uses.insert(at, Channel::ColumnUse{t, rank, bank / banks_per_group_, write});
  } else if (ch.bus_used && ch.bus_last_write != write) {
    ++counters_.turnarounds;
  }
  ch.bus_free_ps = std::max(ch.bus_free_ps, done);
  ch.bus_used = true, ch.bus_last_write = write, ch.bus_last_rank = rank;
  counters_.bus_busy_ps += transfer_ps_;
  r.column_ready_ps = t + column_s_;
  g.column_ready_ps = t + column_l_;
  if (write) {
    r.read_after_write_ps = std::max(r.read_after_write_ps, t + write_to_read_s_);
    g.read_after_write_ps = std::max(g.read_after_write_ps, t + write_to_read_l_);
    k.pre_ready_ps = std::max(k.pre_ready_ps, t + write_to_pre_);
  } else {
    k.pre_ready_ps = std::max(k.pre_ready_ps, t + read_to_pre_);
  }
  k.last_use_ps = t;
  take_command_slot(ch, t);
  emit(write ? DramCommandKind::Write : DramCommandKind::Read, t, ch, rank, bank,
       uint64_t(k.open_row));
  return done;
}

void DramModel::refresh(Channel& ch, uint32_t rank, uint64_t t) {
  Rank& r = ch.ranks[rank];
  r.refresh_end_ps = t + rfc_;
  r.refresh_due_ps += refi_;  // from the due time, so the average rate is exact
  take_command_slot(ch, t);
  ++counters_.refreshes;
  emit(DramCommandKind::Refresh, t, ch, rank, 0, 0);
}

// ------------------------------------------------------------------ scheduler

void DramModel::update_drain_mode(Channel& ch) const {
  // Reads first. Writes drain from the high watermark down to the low one; below it
  // they also go while no read waits, until one does.
  const uint32_t reads = ch.reads_queued, writes = ch.writes_queued;
  if (writes == 0) {
    ch.draining_writes = false;
  } else if (writes >= drain_high_ && !(ch.draining_writes && ch.drain_to_low)) {
    ch.draining_writes = true, ch.drain_to_low = true;
  } else if (!ch.draining_writes) {
    if (reads == 0) ch.draining_writes = true, ch.drain_to_low = false;
  } else if (reads > 0 && (!ch.drain_to_low || writes <= drain_low_)) {
    ch.draining_writes = false;
  }
}

void DramModel::consider(Choice& best, const Choice& c) const {
  if (c.time_ps < best.time_ps ||
      (c.time_ps == best.time_ps &&
       (c.priority < best.priority || (c.priority == best.priority && c.age < best.age))))
    best = c;
}

DramModel::Choice DramModel::decide(Channel& ch, bool requests) {
  return decide_until(ch, requests, UINT64_MAX, UINT64_MAX);
}

DramModel::Choice DramModel::decide_until(Channel& ch, bool requests, uint64_t refresh_horizon,
                                          uint64_t timeout_horizon) {
  Choice best;
  if (++ch.stamp == 0) {  // wrapped: forget all marks
    for (auto* marks : {&ch.active_hit_mark, &ch.any_hit_mark, &ch.column_mark, &ch.row_mark})
      std::fill(marks->begin(), marks->end(), 0);
    ch.stamp = 1;
  }
  const uint32_t stamp = ch.stamp;
  if (requests && !ch.queue.empty()) consider_requests(ch, stamp, best);
  consider_refreshes(ch, refresh_horizon, best);
  if (policy_ == PagePolicy::Timeout) consider_page_timeouts(ch, stamp, timeout_horizon, best);
  return best;
}

// FR-FCFS over the queue in the direction being served: row hits first (each bank's
// oldest), then row commands for each bank's oldest request.
void DramModel::consider_requests(Channel& ch, uint32_t stamp, Choice& best) {
  const uint32_t banks = config_.banks;
  update_drain_mode(ch);
  const bool writes = ch.draining_writes;
  // Banks with a queued hit on their open row: of the serviced direction (their row
  // stays open for it), of any direction (the page policies keep the row).
  for (const Pending& p : ch.queue) {
    const size_t b = size_t(p.where.rank) * banks + p.where.bank;
    if (ch.banks[b].open_row != int64_t(p.where.row)) continue;
    ch.any_hit_mark[b] = stamp;
    if (p.request.write == writes) ch.active_hit_mark[b] = stamp;
  }
  for (size_t i = 0; i < ch.queue.size(); ++i) {
    const Pending& p = ch.queue[i];
    const uint32_t r = p.where.rank, bank = p.where.bank;
    const size_t b = size_t(r) * banks + bank;
    if (p.request.write != writes) {
      // A row activated for a request of the other direction is finished first: its
      // column command goes (the bus turns for it) rather than the row being closed
      // unused by the direction now served, which would cost the activate again.
      const Bank& k = ch.banks[b];
      if (k.opened_for != int8_t(p.request.write) || k.open_row != int64_t(p.where.row) ||
          ch.column_mark[b] == stamp)
        continue;
      ch.column_mark[b] = stamp;
      Choice c;
      c.age = i, c.rank = r, c.bank = bank;
      c.time_ps = earliest_column(ch, r, bank, p.request.write, p.ready_ps);
      if (c.time_ps >= ch.ranks[r].refresh_due_ps) continue;
      c.priority = 1, c.action = Action::Column;
      consider(best, c);
      continue;
    }
    const uint64_t due = ch.ranks[r].refresh_due_ps;  // nothing new for the rank from then
    Choice c;
    c.age = i, c.rank = r, c.bank = bank;
    if (ch.banks[b].open_row == int64_t(p.where.row)) {
      if (ch.column_mark[b] == stamp) continue;  // an older hit to this bank goes first
      ch.column_mark[b] = stamp;
      c.time_ps = earliest_column(ch, r, bank, p.request.write, p.ready_ps);
      if (c.time_ps >= due) continue;
      c.priority = 1, c.action = Action::Column;
    } else {
      if (ch.row_mark[b] == stamp) continue;  // row commands serve the bank's oldest
      ch.row_mark[b] = stamp;
      if (ch.active_hit_mark[b] == stamp) continue;  // hits first
      if (ch.banks[b].opened_for == int8_t(!writes)) continue;  // committed to the other direction
      if (ch.banks[b].open_row >= 0) {
        c.time_ps = earliest_precharge(ch, r, bank, p.ready_ps);
        c.action = Action::Precharge, c.conflict = true;
      } else {
        c.time_ps = earliest_activate(ch, r, bank, p.ready_ps);
        if (c.time_ps >= due) continue;
        c.action = Action::Activate;
      }
      c.priority = 2;
    }
    consider(best, c);
  }
}

// Refresh: a rank whose refresh is due closes its banks, then refreshes. Its
// commands come no earlier than the due time, so a later one cannot compete.
void DramModel::consider_refreshes(Channel& ch, uint64_t refresh_horizon, Choice& best) {
  const uint32_t banks = config_.banks;
  for (uint32_t r = 0; r < config_.ranks; ++r) {
    const uint64_t due = ch.ranks[r].refresh_due_ps;
    if (due == UINT64_MAX || due > refresh_horizon || due > best.time_ps) continue;
    bool any_open = false;
    for (uint32_t b = 0; b < banks; ++b) {
      if (bank_of(ch, r, b).open_row < 0) continue;
      any_open = true;
      Choice c;
      c.time_ps = earliest_precharge(ch, r, b, due), c.priority = 0, c.age = 0;
      c.action = Action::Precharge, c.rank = r, c.bank = b;
      consider(best, c);
    }
    if (!any_open) {
      Choice c;
      c.time_ps = earliest_refresh(ch, r, 0), c.priority = 0, c.age = 0;
      c.action = Action::Refresh, c.rank = r;
      consider(best, c);
    }
  }
}

// The timeout page policy: an open row unused for page_timeout_ closes, unless a
// queued request hits it.
void DramModel::consider_page_timeouts(Channel& ch, uint32_t stamp, uint64_t timeout_horizon, Choice& best) {
  const uint32_t banks = config_.banks;
  for (uint32_t r = 0; r < config_.ranks; ++r)
    for (uint32_t bank = 0; bank < banks; ++bank) {
      const size_t b = size_t(r) * banks + bank;
      const Bank& k = ch.banks[b];
      if (k.open_row < 0 || ch.any_hit_mark[b] == stamp) continue;
      const uint64_t deadline = k.last_use_ps + page_timeout_;
      if (deadline > timeout_horizon || deadline > best.time_ps) continue;
      Choice c;
      c.time_ps = earliest_precharge(ch, r, bank, deadline);
      c.priority = 3, c.action = Action::Precharge, c.rank = r, c.bank = bank;
      consider(best, c);
    }
}

void DramModel::count_request(bool write, RowOutcome outcome, uint64_t latency) {
  if (write) {
    ++counters_.writes;
    counters_.bytes_written += access_bytes_;
    counters_.write_latency_sum_ps += latency;
    counters_.write_latency_max_ps = std::max(counters_.write_latency_max_ps, latency);
    write_histogram_ns_[std::min<uint64_t>(latency / 1000, kHistogramBuckets)]++;
  } else {
    ++counters_.reads;
    counters_.bytes += access_bytes_;
    counters_.read_latency_sum_ps += latency;
    counters_.read_latency_max_ps = std::max(counters_.read_latency_max_ps, latency);
    read_histogram_ns_[std::min<uint64_t>(latency / 1000, kHistogramBuckets)]++;
  }
  if (outcome == RowOutcome::Hit) ++counters_.row_hits;
  else if (outcome == RowOutcome::Closed) ++counters_.row_closed;
  else ++counters_.row_conflicts;
}

void DramModel::set_reference_commands(uint64_t row_hits, uint64_t activates, uint64_t precharges,
                                       uint64_t refreshes, uint64_t bus_busy_ps) {
  // The reference tells hits from the rest but not closed banks from conflicts:
  // every non-hit is counted as a miss (closed).
  const uint64_t requests = counters_.reads + counters_.writes;
  counters_.row_hits = std::min(row_hits, requests);
  counters_.row_closed = requests - counters_.row_hits;
  counters_.row_conflicts = 0;
  counters_.activates = activates;
  counters_.precharges = precharges;
  counters_.refreshes = refreshes;
  counters_.bus_busy_ps = bus_busy_ps;
}

void DramModel::set_reference_write_latencies(
    const std::vector<std::pair<uint64_t, uint64_t>>& latency_count) {
  std::fill(write_histogram_ns_.begin(), write_histogram_ns_.end(), 0);
  counters_.write_latency_sum_ps = counters_.write_latency_max_ps = 0;
  for (const auto& [latency, count] : latency_count) {
    counters_.write_latency_sum_ps += latency * count;
    counters_.write_latency_max_ps = std::max(counters_.write_latency_max_ps, latency);
    write_histogram_ns_[std::min<uint64_t>(latency / 1000, kHistogramBuckets)] += count;
  }
}

void DramModel::execute(Channel& ch, const Choice& c, std::vector<DramCompletion>& issued) {
  Bank& k = bank_of(ch, c.rank, c.bank);
  switch (c.action) {
    case Action::Column: {
      const Pending p = ch.queue[c.age];
      ch.queue.erase(ch.queue.begin() + long(c.age));
      (p.request.write ? ch.writes_queued : ch.reads_queued)--;
      const uint64_t done = column(ch, c.rank, c.bank, p.request.write, c.time_ps);
      k.opened_for = -1;
      count_request(p.request.write, p.outcome,
                    done - std::min(done, p.request.arrival_ps));
      issued.push_back({p.request.tag, done, p.outcome, p.request.write});
      if (policy_ == PagePolicy::Closed) {
        // Auto-precharge unless another queued request still hits the row.
        bool hit_waits = false;
        for (const Pending& q : ch.queue)
          if (q.where.rank == c.rank && q.where.bank == c.bank && q.where.row == p.where.row)
            hit_waits = true;
        if (!hit_waits) precharge(ch, c.rank, c.bank, k.pre_ready_ps, false);
      }
      break;
    }
    case Action::Activate: {
      Pending& p = ch.queue[c.age];
      p.outcome = k.conflict_pending ? RowOutcome::Conflict : RowOutcome::Closed;
      k.conflict_pending = false;
      activate(ch, c.rank, c.bank, p.where.row, c.time_ps);
      k.opened_for = int8_t(p.request.write);
      break;
    }
    case Action::Precharge:
      if (c.conflict) k.conflict_pending = true;
      precharge(ch, c.rank, c.bank, c.time_ps, true);
      break;
    case Action::Refresh: refresh(ch, c.rank, c.time_ps); break;
  }
}

void DramModel::run(Channel& ch, uint64_t until, std::vector<DramCompletion>& issued) {
  for (;;) {
    // A choice stays valid until a command executes or a request arrives.
    if (!ch.choice_valid) ch.choice = decide(ch, true), ch.choice_valid = true;
    const Choice& c = ch.choice;
    if (c.time_ps == UINT64_MAX || c.time_ps > until) {
      ch.next_decision_ps = ch.queue.empty() ? UINT64_MAX : c.time_ps;
      return;
    }
    ch.choice_valid = false;
    execute(ch, Choice(c), issued);
  }
}

bool DramModel::can_accept(uint64_t address) const {
  return channels_[map_.decode(address).channel].queue.size() < config_.queue_entries;
}

bool DramModel::idle() const {
  for (auto& ch : channels_)
    if (!ch.queue.empty()) return false;
  return true;
}

void DramModel::enqueue(const DramRequest& request, uint64_t now_ps) {
  const DramAddress where = map_.decode(request.address);
  if (request_observer_) request_observer_({request.arrival_ps, request.address, request.write, where});
  Channel& ch = channels_[where.channel];
  const uint64_t ready = edge(now_ps);
  // Decisions before this request could take part: idle-time refreshes and timeouts,
  // or requests the caller did not advance for.
  if (ready > 0) run(ch, ready - 1, pending_completions_);
  ch.queue.push_back({request, where, ready, RowOutcome::Hit});
  (request.write ? ch.writes_queued : ch.reads_queued)++;
  ch.choice = decide(ch, true), ch.choice_valid = true;
  ch.next_decision_ps = ch.choice.time_ps;
}

bool DramModel::try_enqueue(const DramRequest& request, uint64_t now_ps) {
  if (!can_accept(request.address)) {
    note_rejection();
    return false;
  }
  enqueue(request, now_ps);
  return true;
}

uint64_t DramModel::next_decision_ps() const {
  uint64_t t = UINT64_MAX;
  for (auto& ch : channels_)
    if (!ch.queue.empty()) t = std::min(t, ch.next_decision_ps);
  return t;
}

void DramModel::advance(uint64_t now_ps, std::vector<DramCompletion>& issued) {
  if (!pending_completions_.empty()) {
    issued.insert(issued.end(), pending_completions_.begin(), pending_completions_.end());
    pending_completions_.clear();
  }
  for (auto& ch : channels_)
    if (!ch.queue.empty() && ch.next_decision_ps <= now_ps) run(ch, now_ps, issued);
}

void DramModel::settle(uint64_t now_ps) {
  for (auto& ch : channels_) run(ch, now_ps, pending_completions_);
}

// ---------------------------------------------------------------- loosely timed

uint64_t DramModel::lt_access(uint64_t address, bool write, uint64_t now_ps, RowOutcome* outcome_out) {
  lt_ = true;
  const DramAddress w = map_.decode(address);
  if (request_observer_) request_observer_({now_ps, address, write, w});
  Channel& ch = channels_[w.channel];
  // Requests come nearly in time order, but not quite: one that waited upstream (for
  // an MSHR, say) arrives after later ones were placed. It is placed at its own time
  // among them (bank state and the calendars below), not behind the latest arrival;
  // only one older than the calendars' horizon is moved up to it.
  ch.lt_latest_ps = std::max(ch.lt_latest_ps, edge(now_ps));
  const uint64_t t0 = std::max(edge(now_ps), ch.lt_latest_ps - std::min(ch.lt_latest_ps, kLtHorizonPs));
  Bank& k = bank_of(ch, w.rank, w.bank);
  if (policy_ == PagePolicy::Closed) {
    // A row auto-precharges after its column command unless the next request to the
    // bank hits it and had arrived by then (it would have been queued behind it).
    for (uint32_t r = 0; r < config_.ranks; ++r)
      for (uint32_t b = 0; b < config_.banks; ++b) {
        Bank& other = bank_of(ch, r, b);
        if (other.open_row < 0 || other.auto_close_after_ps == UINT64_MAX) continue;
        const bool mine = &other == &k;
        if (mine && other.open_row == int64_t(w.row) && other.auto_close_after_ps >= t0)
          other.auto_close_after_ps = UINT64_MAX;  // kept open for this hit
        else if (mine || other.auto_close_after_ps < t0)
          precharge(ch, r, b, other.pre_ready_ps, false);
      }
  }
  // First the refreshes due by the time this request reaches the data bus, and the
  // rows idle past the timeout when it arrives, each as early as the rules allow.
  for (;;) {
    const Choice c = decide_until(ch, false, std::max(t0, ch.bus_free_ps), t0);
    if (c.time_ps == UINT64_MAX) break;
    execute(ch, c, pending_completions_);  // never a column command: nothing is queued
  }
  // Command slots, columns and activates older than the horizon are never asked for
  // again (tRTRS, tCCD, tWTR, tFAW and the bus span far less than it); they are
  // dropped in batches, not on every call.
  if (++ch.lt_calls_since_prune >= 1024) {
    ch.lt_calls_since_prune = 0;
    const uint64_t oldest = ch.lt_latest_ps - std::min(ch.lt_latest_ps, 2 * kLtHorizonPs);
    auto& slots = ch.reserved_slots;
    slots.erase(slots.begin(), std::lower_bound(slots.begin(), slots.end(), oldest));
    auto& uses = ch.lt_columns;
    uses.erase(uses.begin(), std::lower_bound(uses.begin(), uses.end(), oldest,
                                              [](const Channel::ColumnUse& u, uint64_t x) {
                                                return u.time_ps < x;
                                              }));
    for (Rank& rank : ch.ranks) {
      auto& acts = rank.lt_acts;
      acts.erase(acts.begin(), std::lower_bound(acts.begin(), acts.end(), std::make_pair(oldest, 0u)));
    }
  }
  RowOutcome outcome = RowOutcome::Hit;
  if (k.open_row != int64_t(w.row)) {
    outcome = RowOutcome::Closed;
    if (k.open_row >= 0) {
      precharge(ch, w.rank, w.bank, earliest_precharge(ch, w.rank, w.bank, t0), true);
      outcome = RowOutcome::Conflict;
    }
    activate(ch, w.rank, w.bank, w.row, earliest_activate(ch, w.rank, w.bank, t0));
  }
  const uint64_t issue = earliest_column(ch, w.rank, w.bank, write, t0);
  const uint64_t done = column(ch, w.rank, w.bank, write, issue);
  if (policy_ == PagePolicy::Closed) k.auto_close_after_ps = issue;  // decided by the next request
  count_request(write, outcome, done - now_ps);
  if (outcome_out) *outcome_out = outcome;
  return done;
}

void DramModel::count_access(uint64_t address, bool write) {
  if (request_observer_) request_observer_({0, address, write, map_.decode(address)});
  if (write) {
    ++counters_.writes;
    counters_.bytes_written += access_bytes_;
  } else {
    ++counters_.reads;
    counters_.bytes += access_bytes_;
  }
}

// ------------------------------------------------------------------ statistics

void DramModel::reset_counters() {
  counters_ = Counters{};
  std::fill(read_histogram_ns_.begin(), read_histogram_ns_.end(), 0);
  std::fill(write_histogram_ns_.begin(), write_histogram_ns_.end(), 0);
}

double DramModel::latency_percentile_ns(double fraction, bool write) const {
  const std::vector<uint64_t>& histogram = write ? write_histogram_ns_ : read_histogram_ns_;
  uint64_t total = 0;
  for (uint64_t n : histogram) total += n;
  if (total == 0) return 0;
  const uint64_t wanted = std::max<uint64_t>(1, uint64_t(std::ceil(fraction * double(total))));
  uint64_t seen = 0;
  for (size_t i = 0; i < histogram.size(); ++i) {
    seen += histogram[i];
    if (seen >= wanted) return double(i);
  }
  return double(kHistogramBuckets);
}

void DramModel::report(StatsRegistry& s, const std::string& prefix, bool row_timing, bool timed,
                       uint64_t sim_ps) const {
  const Counters& c = counters_;
  s.set(prefix + ".reads", c.reads, "requests", "line reads that reached DRAM");
  s.set(prefix + ".bytes", c.bytes, "bytes", "bytes read from DRAM");
  s.set(prefix + ".writes", c.writes, "requests", "line writes that reached DRAM");
  s.set(prefix + ".bytes_written", c.bytes_written, "bytes", "bytes written to DRAM");
  s.set(prefix + ".channels", config_.channels, "channels", "DRAM channels");
  s.set_real(prefix + ".peak_bandwidth", peak_bytes_per_second() / 1e9, "GB/s",
             "sum over channels of access bytes per tBURST");
  if (row_timing) {
    s.set(prefix + ".row_hits", c.row_hits, "requests", "reads and writes to the open row");
    s.set(prefix + ".row_misses", c.row_closed, "requests",
          "reads and writes to a closed (precharged) bank");
    s.set(prefix + ".row_conflicts", c.row_conflicts, "requests",
          "reads and writes to a bank with another row open");
    s.set(prefix + ".activates", c.activates, "commands", "row activates (ACT)");
    s.set(prefix + ".precharges", c.precharges, "commands",
          "row precharges (PRE, including auto-precharge, timeout and refresh)");
    s.set(prefix + ".refreshes", c.refreshes, "commands",
          "all-bank refreshes (REF) over all ranks");
    s.set(prefix + ".turnarounds", c.turnarounds, "events",
          "data bus switches between reading and writing");
    s.set(prefix + ".queue_full_stalls", c.queue_full_refusals, "events",
          "attempts refused because a channel queue was full");
  }
  if (timed) {
    auto mean_ns = [](uint64_t sum, uint64_t n) {
      return n ? double(sum) / double(n) / 1000.0 : 0;
    };
    s.set_real(prefix + ".latency_avg", mean_ns(c.read_latency_sum_ps, c.reads), "ns",
               "mean read latency, first attempt to last data beat (queue-full waits included)");
    s.set_real(prefix + ".latency_p99", latency_percentile_ns(0.99, false), "ns",
               "99th percentile read latency (1 ns resolution)");
    s.set_real(prefix + ".latency_max", double(c.read_latency_max_ps) / 1000.0, "ns",
               "largest read latency");
    s.set_real(prefix + ".write_latency_avg", mean_ns(c.write_latency_sum_ps, c.writes), "ns",
               "mean write latency, first attempt to last data beat written (posted)");
    s.set_real(prefix + ".write_latency_p99", latency_percentile_ns(0.99, true), "ns",
               "99th percentile write latency (1 ns resolution)");
    s.set_real(prefix + ".write_latency_max", double(c.write_latency_max_ps) / 1000.0, "ns",
               "largest write latency");
    const double seconds = double(sim_ps) * 1e-12;
    s.set_real(prefix + ".bandwidth", seconds > 0 ? double(c.bytes) / seconds / 1e9 : 0, "GB/s",
               "achieved read bandwidth over the simulated time");
    s.set_real(prefix + ".write_bandwidth",
               seconds > 0 ? double(c.bytes_written) / seconds / 1e9 : 0, "GB/s",
               "achieved write bandwidth over the simulated time");
    s.set_real(prefix + ".bus_utilisation",
               sim_ps ? double(c.bus_busy_ps) / (double(sim_ps) * config_.channels) : 0, "ratio",
               "fraction of time the data buses carried data");
  }
}

}  // namespace rtsim::sim
