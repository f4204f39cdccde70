#include <rtsim/model/sim/dram.h>

#include <algorithm>
#include <cmath>

namespace rtsim::sim {

namespace {
// lt: how far before the latest arrival a request may still be placed at its own time.
constexpr uint64_t kLtHorizonPs = 4'000'000;
constexpr size_t kHistogramBuckets = 16384;  // 1 ns each

DramConfig with_one_group_at_least(DramConfig config) {
  config.bank_groups = std::max<uint32_t>(1, config.bank_groups);
  return config;
}
}  // namespace

DramModel::DramModel(const DramConfig& config, uint32_t access_bytes)
    : config_(with_one_group_at_least(config)), map_(config, access_bytes),
      policy_(parse_page_policy(config.page_policy)), access_bytes_(access_bytes),
      device_(config, access_bytes, counters_), refresh_(device_.timings(), config.channels, config.ranks),
      scheduler_(config, config.channels, size_t(config.ranks) * config.banks), channels_(config.channels),
      read_histogram_ns_(kHistogramBuckets + 1, 0), write_histogram_ns_(kHistogramBuckets + 1, 0) {
  for (Channel& ch : channels_) ch.queue.entries.reserve(config.queue_entries);
}

uint64_t DramModel::latency_ps(RowOutcome outcome) const {
  const DramTimings& t = device_.timings();
  switch (outcome) {
    case RowOutcome::Hit: return t.cl + t.transfer;
    case RowOutcome::Closed: return t.rcd + t.cl + t.transfer;
    case RowOutcome::Conflict: return t.rp + t.rcd + t.cl + t.transfer;
  }
  return 0;
}

double DramModel::peak_bytes_per_second() const {
  return double(config_.channels) * access_bytes_ / (double(transfer_ps()) * 1e-12);
}

// ------------------------------------------------------------------ decisions

DramCandidate DramModel::decide(uint32_t c, bool requests) {
  return decide_until(c, requests, UINT64_MAX, UINT64_MAX);
}

// The parts' proposals, in this order (the first of equals wins): the queued requests'
// column and row commands (the scheduler), the refreshes due, the timeout policy's
// precharges.
DramCandidate DramModel::decide_until(uint32_t c, bool requests, uint64_t refresh_horizon,
                                      uint64_t timeout_horizon) {
  DramCandidate best;
  DramDevice::Channel& ch = device_.channel(c);
  scheduler_.begin(c);
  if (requests && !channels_[c].queue.entries.empty())
    scheduler_.offer_requests(device_, ch, channels_[c].queue, refresh_, best);
  refresh_.offer(device_, ch, refresh_horizon, best);
  if (policy_ == PagePolicy::Timeout)
    device_.offer_page_timeouts(ch, timeout_horizon,
                                [&](size_t bank) { return scheduler_.has_queued_hit(c, bank); }, best);
  return best;
}

void DramModel::execute(uint32_t c, const DramCandidate& choice, std::vector<DramCompletion>& issued) {
  DramDevice::Channel& ch = device_.channel(c);
  DramQueue& queue = channels_[c].queue;
  DramDevice::Bank& k = device_.bank_state(ch, choice.rank, choice.bank);
  switch (choice.action) {
    case DramCandidate::Action::Column: {
      const DramPending p = queue.entries[choice.age];
      queue.entries.erase(queue.entries.begin() + long(choice.age));
      (p.request.write ? queue.writes : queue.reads)--;
      const uint64_t done = device_.column(ch, choice.rank, choice.bank, p.request.write, choice.time_ps);
      k.opened_for = -1;
      count_request(p.request.write, p.outcome, done - std::min(done, p.request.arrival_ps));
      issued.push_back({p.request.tag, done, p.outcome, p.request.write});
      if (policy_ == PagePolicy::Closed) {
        // Auto-precharge unless another queued request still hits the row.
        bool hit_waits = false;
        for (const DramPending& q : queue.entries)
          if (q.where.rank == choice.rank && q.where.bank == choice.bank && q.where.row == p.where.row)
            hit_waits = true;
        if (!hit_waits) device_.precharge(ch, choice.rank, choice.bank, k.pre_ready_ps, false);
      }
      break;
    }
    case DramCandidate::Action::Activate: {
      DramPending& p = queue.entries[choice.age];
      p.outcome = k.conflict_pending ? RowOutcome::Conflict : RowOutcome::Closed;
      k.conflict_pending = false;
      device_.activate(ch, choice.rank, choice.bank, p.where.row, choice.time_ps);
      k.opened_for = int8_t(p.request.write);
      break;
    }
    case DramCandidate::Action::Precharge:
      if (choice.conflict) k.conflict_pending = true;
      device_.precharge(ch, choice.rank, choice.bank, choice.time_ps, true);
      break;
    case DramCandidate::Action::Refresh:
      device_.refresh(ch, choice.rank, choice.time_ps);
      refresh_.refreshed(c, choice.rank);
      break;
  }
}

void DramModel::run(uint32_t c, uint64_t until, std::vector<DramCompletion>& issued) {
  Channel& ch = channels_[c];
  for (;;) {
    // A choice stays valid until a command executes or a request arrives.
    if (!ch.choice_valid) ch.choice = decide(c, true), ch.choice_valid = true;
    const DramCandidate& choice = ch.choice;
    if (choice.time_ps == UINT64_MAX || choice.time_ps > until) {
      ch.next_decision_ps = ch.queue.entries.empty() ? UINT64_MAX : choice.time_ps;
      return;
    }
    ch.choice_valid = false;
    execute(c, DramCandidate(choice), issued);
  }
}

// ---------------------------------------------------------------- queued path

bool DramModel::can_accept(uint64_t address) const {
  return channels_[map_.decode(address).channel].queue.entries.size() < config_.queue_entries;
}

bool DramModel::idle() const {
  for (const Channel& ch : channels_)
    if (!ch.queue.entries.empty()) return false;
  return true;
}

void DramModel::enqueue(const DramRequest& request, uint64_t now_ps) {
  const DramAddress where = map_.decode(request.address);
  if (request_observer_) request_observer_({request.arrival_ps, request.address, request.write, where});
  const uint32_t c = where.channel;
  Channel& ch = channels_[c];
  const uint64_t ready = device_.timings().edge(now_ps);
  // Decisions before this request could take part: idle-time refreshes and timeouts,
  // or requests the caller did not advance for.
  if (ready > 0) run(c, ready - 1, pending_completions_);
  ch.queue.entries.push_back({request, where, ready, RowOutcome::Hit});
  (request.write ? ch.queue.writes : ch.queue.reads)++;
  ch.choice = decide(c, true), ch.choice_valid = true;
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
  for (const Channel& ch : channels_)
    if (!ch.queue.entries.empty()) t = std::min(t, ch.next_decision_ps);
  return t;
}

void DramModel::advance(uint64_t now_ps, std::vector<DramCompletion>& issued) {
  if (!pending_completions_.empty()) {
    issued.insert(issued.end(), pending_completions_.begin(), pending_completions_.end());
    pending_completions_.clear();
  }
  for (uint32_t c = 0; c < channels_.size(); ++c)
    if (!channels_[c].queue.entries.empty() && channels_[c].next_decision_ps <= now_ps)
      run(c, now_ps, issued);
}

void DramModel::settle(uint64_t now_ps) {
  for (uint32_t c = 0; c < channels_.size(); ++c) run(c, now_ps, pending_completions_);
}

// ---------------------------------------------------------------- loosely timed

uint64_t DramModel::lt_access(uint64_t address, bool write, uint64_t now_ps, RowOutcome* outcome_out) {
  device_.place_ahead();
  const DramAddress w = map_.decode(address);
  if (request_observer_) request_observer_({now_ps, address, write, w});
  const uint32_t c = w.channel;
  Channel& ch = channels_[c];
  DramDevice::Channel& dev = device_.channel(c);
  const DramTimings& t = device_.timings();
  // Requests come nearly in time order, but not quite: one that waited upstream (for
  // an MSHR, say) arrives after later ones were placed. It is placed at its own time
  // among them (bank state and the device's calendars), not behind the latest arrival;
  // only one older than the calendars' horizon is moved up to it.
  ch.lt_latest_ps = std::max(ch.lt_latest_ps, t.edge(now_ps));
  const uint64_t t0 = std::max(t.edge(now_ps), ch.lt_latest_ps - std::min(ch.lt_latest_ps, kLtHorizonPs));
  DramDevice::Bank& k = device_.bank_state(dev, w.rank, w.bank);
  if (policy_ == PagePolicy::Closed) {
    // A row auto-precharges after its column command unless the next request to the
    // bank hits it and had arrived by then (it would have been queued behind it).
    for (uint32_t r = 0; r < config_.ranks; ++r)
      for (uint32_t b = 0; b < config_.banks; ++b) {
        DramDevice::Bank& other = device_.bank_state(dev, r, b);
        if (other.open_row < 0 || other.auto_close_after_ps == UINT64_MAX) continue;
        const bool mine = &other == &k;
        if (mine && other.open_row == int64_t(w.row) && other.auto_close_after_ps >= t0)
          other.auto_close_after_ps = UINT64_MAX;  // kept open for this hit
        else if (mine || other.auto_close_after_ps < t0)
          device_.precharge(dev, r, b, other.pre_ready_ps, false);
      }
  }
  // First the refreshes due by the time this request reaches the data bus, and the
  // rows idle past the timeout when it arrives, each as early as the rules allow.
  for (;;) {
    const DramCandidate choice = decide_until(c, false, std::max(t0, dev.bus_free_ps), t0);
    if (choice.time_ps == UINT64_MAX) break;
    execute(c, choice, pending_completions_);  // never a column command: nothing is queued
  }
  // Command slots, columns and activates older than the horizon are never asked for
  // again (tRTRS, tCCD, tWTR, tFAW and the bus span far less than it); they are
  // dropped in batches, not on every call.
  if (++ch.lt_calls_since_prune >= 1024) {
    ch.lt_calls_since_prune = 0;
    device_.forget_before(dev, ch.lt_latest_ps - std::min(ch.lt_latest_ps, 2 * kLtHorizonPs));
  }
  RowOutcome outcome = RowOutcome::Hit;
  if (k.open_row != int64_t(w.row)) {
    outcome = RowOutcome::Closed;
    if (k.open_row >= 0) {
      device_.precharge(dev, w.rank, w.bank, device_.earliest_precharge(dev, w.rank, w.bank, t0), true);
      outcome = RowOutcome::Conflict;
    }
    device_.activate(dev, w.rank, w.bank, w.row, device_.earliest_activate(dev, w.rank, w.bank, t0));
  }
  const uint64_t issue = device_.earliest_column(dev, w.rank, w.bank, write, t0);
  const uint64_t done = device_.column(dev, w.rank, w.bank, write, issue);
  if (policy_ == PagePolicy::Closed) k.auto_close_after_ps = issue;  // decided by the next request
  count_request(write, outcome, done - now_ps);
  if (outcome_out) *outcome_out = outcome;
  return done;
}

// ------------------------------------------------------------------ statistics

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
