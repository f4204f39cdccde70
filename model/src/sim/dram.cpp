#include <rtsim/model/sim/dram.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace rtsim::sim {

namespace {
uint32_t log2_exact(uint64_t v) {
  uint32_t bits = 0;
  while ((uint64_t(1) << bits) < v) ++bits;
  return bits;
}
constexpr size_t kHistogramBuckets = 16384;  // 1 ns each
}  // namespace

DramAddressMap::DramAddressMap(const DramConfig& c, uint32_t access_bytes) {
  offset_bits_ = log2_exact(access_bytes);
  const uint32_t column_bits = log2_exact(std::max<uint64_t>(1, c.row_bytes / access_bytes));
  std::vector<std::string> names;
  std::stringstream in(c.address_mapping);
  std::string field;
  while (std::getline(in, field, ':')) names.push_back(field);
  // Least significant first: the last name sits right above the access offset.
  uint32_t shift = offset_bits_;
  for (auto it = names.rbegin(); it != names.rend(); ++it) {
    Field f{};
    if (*it == "row") f.which = 0, f.bits = 64 - shift;  // whatever is left
    else if (*it == "rank") f.which = 1, f.bits = log2_exact(c.ranks);
    else if (*it == "bank") f.which = 2, f.bits = log2_exact(c.banks);
    else if (*it == "column") f.which = 3, f.bits = column_bits;
    else if (*it == "channel") f.which = 4, f.bits = log2_exact(c.channels);
    else throw InputError("dram.address_mapping", "unknown field '" + *it + "'");
    if (f.which == 0 && it + 1 != names.rend())
      f.bits = 0;  // row not on top: computed below
    f.shift = shift;
    fields_.push_back(f);
    shift += f.bits;
  }
  // A row field below other fields gets a fixed width so the fields above have room;
  // row numbers then wrap, which only matters for images larger than 2^40 bytes.
  uint32_t total = offset_bits_;
  for (auto& f : fields_) {
    if (f.which == 0 && f.bits == 0) f.bits = 24;
    f.shift = total;
    total += f.bits;
  }
}

DramAddress DramAddressMap::decode(uint64_t address) const {
  DramAddress out;
  for (const Field& f : fields_) {
    const uint64_t value = f.bits >= 64 ? (address >> f.shift)
                                        : (address >> f.shift) & ((uint64_t(1) << f.bits) - 1);
    switch (f.which) {
      case 0: out.row = value; break;
      case 1: out.rank = uint32_t(value); break;
      case 2: out.bank = uint32_t(value); break;
      case 3: out.column = uint32_t(value); break;
      case 4: out.channel = uint32_t(value); break;
    }
  }
  return out;
}

DramModel::DramModel(const DramConfig& config, uint32_t access_bytes)
    : config_(config), map_(config, access_bytes), access_bytes_(access_bytes),
      tck_(config.tck_ps), channels_(config.channels),
      latency_histogram_ns_(kHistogramBuckets + 1, 0) {
  const uint64_t bursts = (access_bytes + config.burst_bytes - 1) / config.burst_bytes;
  transfer_ps_ = bursts * config.burst_cycles * tck_;
  for (auto& ch : channels_) ch.banks.resize(size_t(config.ranks) * config.banks);
}

uint64_t DramModel::latency_ps(RowOutcome outcome) const {
  const uint64_t cl = uint64_t(config_.tcl) * tck_;
  switch (outcome) {
    case RowOutcome::Hit: return cl + transfer_ps_;
    case RowOutcome::Closed: return uint64_t(config_.trcd) * tck_ + cl + transfer_ps_;
    case RowOutcome::Conflict:
      return uint64_t(config_.trp + config_.trcd) * tck_ + cl + transfer_ps_;
  }
  return 0;
}

double DramModel::peak_bytes_per_second() const {
  return double(config_.channels) * access_bytes_ / (double(transfer_ps_) * 1e-12);
}

bool DramModel::can_accept(uint64_t address) const {
  return channels_[map_.decode(address).channel].queue.size() < config_.queue_entries;
}

bool DramModel::idle() const {
  for (auto& ch : channels_)
    if (!ch.queue.empty()) return false;
  return true;
}

void DramModel::enqueue(const DramRequest& request) {
  Pending p{request, map_.decode(request.address), false, RowOutcome::Hit};
  Channel& ch = channels_[p.where.channel];
  ch.queue.push_back(p);
  ch.next_decision_ps = std::min(ch.next_decision_ps, std::max(request.arrival_ps,
                                                              ch.command_free_ps));
}

uint64_t DramModel::next_decision_ps() const {
  uint64_t t = UINT64_MAX;
  for (auto& ch : channels_)
    if (!ch.queue.empty()) t = std::min(t, ch.next_decision_ps);
  return t;
}

void DramModel::prepare_rows(Channel& ch, uint64_t now) {
  // Row commands (precharge, activate) go to every bank whose oldest waiting request
  // needs another row, as soon as no queued request still hits the open row; they
  // overlap the data transfers of other banks.
  for (size_t i = 0; i < ch.queue.size(); ++i) {
    Pending& p = ch.queue[i];
    if (p.prepared) continue;
    Bank& bank = ch.banks[size_t(p.where.rank) * config_.banks + p.where.bank];
    if (bank.open_row == int64_t(p.where.row)) {
      p.prepared = true;
      p.outcome = RowOutcome::Hit;
      continue;
    }
    bool blocked = false;  // an older request to this bank, or a queued hit on its open row
    for (size_t j = 0; j < ch.queue.size() && !blocked; ++j) {
      const Pending& q = ch.queue[j];
      if (j == i || q.where.rank != p.where.rank || q.where.bank != p.where.bank) continue;
      if (int64_t(q.where.row) == bank.open_row || (j < i && !q.prepared)) blocked = true;
    }
    if (blocked) continue;
    uint64_t act;
    if (bank.open_row < 0) {
      p.outcome = RowOutcome::Closed;
      act = std::max(now, bank.act_ready_ps);
    } else {
      p.outcome = RowOutcome::Conflict;
      // Precharge once the row has been open tRAS and its last column command issued.
      const uint64_t pre = std::max({now, bank.act_ps + uint64_t(config_.tras) * tck_,
                                     bank.col_ready_ps});
      act = pre + uint64_t(config_.trp) * tck_;
    }
    bank.open_row = int64_t(p.where.row);
    bank.act_ps = act;
    bank.col_ready_ps = act + uint64_t(config_.trcd) * tck_;
    p.prepared = true;
  }
}

void DramModel::record_latency(uint64_t latency) {
  counters_.latency_sum_ps += latency;
  counters_.latency_max_ps = std::max(counters_.latency_max_ps, latency);
  latency_histogram_ns_[std::min<uint64_t>(latency / 1000, kHistogramBuckets)]++;
}

void DramModel::schedule(Channel& ch, uint64_t now, std::vector<DramCompletion>& issued) {
  while (!ch.queue.empty() && now >= ch.command_free_ps) {
    prepare_rows(ch, now);
    // Column reads: the oldest request whose row is open and whose data, issued
    // now, would not arrive before the bus frees (issuing later would idle the bus).
    size_t chosen = SIZE_MAX;
    uint64_t wake = UINT64_MAX;
    for (size_t i = 0; i < ch.queue.size(); ++i) {
      const Pending& p = ch.queue[i];
      if (!p.prepared) continue;
      const Bank& bank = ch.banks[size_t(p.where.rank) * config_.banks + p.where.bank];
      if (bank.open_row != int64_t(p.where.row)) continue;
      if (bank.col_ready_ps > now) {  // the bank cannot take a column command yet
        wake = std::min(wake, bank.col_ready_ps);
        continue;
      }
      const uint64_t start = now + uint64_t(config_.tcl) * tck_;
      if (start >= ch.bus_free_ps) {
        chosen = i;
        break;
      }
      wake = std::min(wake, ch.bus_free_ps - uint64_t(config_.tcl) * tck_);
    }
    if (chosen == SIZE_MAX) {
      ch.next_decision_ps = wake == UINT64_MAX ? std::max(now + 1, ch.bus_free_ps) : wake;
      return;
    }
    const Pending p = ch.queue[chosen];
    ch.queue.erase(ch.queue.begin() + chosen);
    Bank& bank = ch.banks[size_t(p.where.rank) * config_.banks + p.where.bank];
    const uint64_t col = now;
    const uint64_t start = std::max(col + uint64_t(config_.tcl) * tck_, ch.bus_free_ps);
    const uint64_t done = start + transfer_ps_;
    // Column commands to one bank are spaced by a burst (tCCD).
    bank.col_ready_ps = col + uint64_t(config_.burst_cycles) * tck_;
    ch.bus_free_ps = done;
    ch.command_free_ps = now + tck_;
    counters_.reads++;
    counters_.bytes += access_bytes_;
    counters_.bus_busy_ps += transfer_ps_;
    if (p.outcome == RowOutcome::Hit) counters_.row_hits++;
    else if (p.outcome == RowOutcome::Closed) counters_.row_closed++;
    else counters_.row_conflicts++;
    record_latency(done - p.request.arrival_ps);
    issued.push_back({p.request.tag, done, p.outcome});
  }
  ch.next_decision_ps = ch.queue.empty() ? UINT64_MAX : std::max(now + 1, ch.command_free_ps);
}

void DramModel::advance(uint64_t now_ps, std::vector<DramCompletion>& issued) {
  for (auto& ch : channels_)
    if (!ch.queue.empty() && ch.next_decision_ps <= now_ps) schedule(ch, now_ps, issued);
}

uint64_t DramModel::lt_access(uint64_t address, bool, uint64_t now_ps) {
  const uint64_t window_ps = 0;
  Channel& ch = channels_[map_.decode(address).channel];
  const uint64_t ready = now_ps + uint64_t(config_.trcd + config_.tcl) * tck_;
  const uint64_t start =
      std::max(ready, ch.bus_free_ps > window_ps ? ch.bus_free_ps - window_ps : 0);
  const uint64_t done = start + transfer_ps_;
  ch.bus_free_ps = std::max(ch.bus_free_ps, start) + transfer_ps_;
  counters_.reads++;
  counters_.bytes += access_bytes_;
  counters_.bus_busy_ps += transfer_ps_;
  record_latency(done - now_ps);
  return done;
}

void DramModel::count_access(uint64_t, bool) {
  counters_.reads++;
  counters_.bytes += access_bytes_;
}

double DramModel::latency_percentile_ns(double fraction) const {
  uint64_t total = 0;
  for (uint64_t n : latency_histogram_ns_) total += n;
  if (total == 0) return 0;
  const uint64_t wanted = uint64_t(std::ceil(fraction * double(total)));
  uint64_t seen = 0;
  for (size_t i = 0; i < latency_histogram_ns_.size(); ++i) {
    seen += latency_histogram_ns_[i];
    if (seen >= wanted) return double(i);
  }
  return double(kHistogramBuckets);
}

void DramModel::report(StatsRegistry& s, const std::string& prefix, bool row_timing, bool timed,
                       uint64_t sim_ps) const {
  const Counters& c = counters_;
  s.set(prefix + ".reads", c.reads, "requests", "line reads that reached DRAM");
  s.set(prefix + ".bytes", c.bytes, "bytes", "bytes read from DRAM");
  s.set(prefix + ".channels", config_.channels, "channels", "DRAM channels");
  s.set_real(prefix + ".peak_bandwidth", peak_bytes_per_second() / 1e9, "GB/s",
             "sum over channels of access bytes per tBURST");
  if (row_timing) {
    s.set(prefix + ".row_hits", c.row_hits, "requests", "reads to the open row");
    s.set(prefix + ".row_misses", c.row_closed, "requests", "reads to a closed (precharged) bank");
    s.set(prefix + ".row_conflicts", c.row_conflicts, "requests",
          "reads to a bank with another row open");
    s.set(prefix + ".queue_full_stalls", c.queue_full_rejections, "events",
          "requests refused because a channel queue was full");
  }
  if (timed) {
    const double reads = double(std::max<uint64_t>(1, c.reads));
    s.set_real(prefix + ".latency_avg", c.reads ? double(c.latency_sum_ps) / reads / 1000.0 : 0,
               "ns", "mean arrival-to-last-beat latency");
    s.set_real(prefix + ".latency_p99", latency_percentile_ns(0.99), "ns",
               "99th percentile latency (1 ns resolution)");
    s.set_real(prefix + ".latency_max", double(c.latency_max_ps) / 1000.0, "ns",
               "largest latency");
    const double seconds = double(sim_ps) * 1e-12;
    s.set_real(prefix + ".bandwidth", seconds > 0 ? double(c.bytes) / seconds / 1e9 : 0, "GB/s",
               "achieved read bandwidth over the simulated time");
    s.set_real(prefix + ".bus_utilisation",
               sim_ps ? double(c.bus_busy_ps) / (double(sim_ps) * config_.channels) : 0, "ratio",
               "fraction of time the data buses carried data");
  }
}

}  // namespace rtsim::sim
