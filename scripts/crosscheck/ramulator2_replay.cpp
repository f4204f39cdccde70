// Replays an rtsim DRAM trace (dramsim3 format, `simulate --dram-trace-out`) through
// Ramulator 2 (CMU-SAFARI/ramulator2) as `rtsim dram-replay` replays it through
// ours: in trace order, each request entering at its trace cycle or, when its
// channel refuses it, on a later cycle (the ones behind it wait); read latency from
// the trace cycle to Ramulator's depart cycle. Built by scripts/crosscheck-ramulator2.sh
// against the user's own Ramulator 2 build; only its public headers are used.
//
//   ramulator2_replay CONFIG.yaml TRACE GROUPS BANKS_PER_GROUP LINE_COLUMNS
//                     CHANNEL_BITS HAS_RANK SPLITS ROW_BITS
//
// The trace's addresses are our default mapping's bit fields (line offset 6 bits,
// then channel, bank group, column, bank, row; one rank): they become Ramulator's
// address vector directly (its pass-through mappers), so both models see the same
// channel, bank group, bank, row and column. A line is SPLITS transactions when
// Ramulator's transaction is smaller (GDDR6, LPDDR5: two of 32 bytes); the line is
// done when its last one is. Prints one JSON line with dram-replay's keys.
#include <ramulator/base/config.h>
#include <ramulator/base/factory.h>
#include <ramulator/base/request.h>
#include <ramulator/frontend/i_frontend.h>
#include <ramulator/memory_system/i_memory_system.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

int bits_for(int values) {
  int b = 0;
  while ((1 << b) < values) ++b;
  return b;
}

// Sums one statistic over every controller in Ramulator's printed statistics.
double stat_sum(const std::string& stats, const std::string& key) {
  std::istringstream in(stats);
  std::string line;
  double sum = 0;
  while (std::getline(in, line)) {
    const size_t at = line.find_first_not_of(' ');
    if (at == std::string::npos || line.compare(at, key.size() + 1, key + ":") != 0) continue;
    sum += std::stod(line.substr(at + key.size() + 1));
  }
  return sum;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 10) {
    std::fprintf(stderr, "usage: %s CONFIG TRACE GROUPS BANKS_PER_GROUP LINE_COLUMNS CHANNEL_BITS "
                         "HAS_RANK SPLITS ROW_BITS\n", argv[0]);
    return 2;
  }
  const int groups = std::stoi(argv[3]), per_group = std::stoi(argv[4]), columns = std::stoi(argv[5]);
  const int channel_bits = std::stoi(argv[6]), has_rank = std::stoi(argv[7]);
  const int splits = std::stoi(argv[8]), row_bits = std::stoi(argv[9]);
  auto config = Ramulator::Config::parse_config_file(argv[1]);
  Ramulator::IFrontEnd* frontend = Ramulator::Factory::create_frontend(config);
  Ramulator::IMemorySystem* memory = Ramulator::Factory::create_memory_system(config);
  frontend->connect_memory_system(memory);
  memory->connect_frontend(frontend);
  const int tx = memory->get_tx_bytes();
  const double tck_ns = memory->get_tCK();

  struct Entry {
    uint64_t cycle;
    bool write;
    std::vector<int> vec;
    int64_t address;
  };
  std::vector<Entry> entries;
  {
    std::ifstream in(argv[2]);
    std::string address, op;
    uint64_t cycle;
    while (in >> address >> op >> cycle) {
      const uint64_t full = std::stoull(address, nullptr, 16);
      uint64_t x = full >> 6;
      const int channel = int(x & ((1u << channel_bits) - 1));
      x >>= channel_bits;
      const int group = int(x & uint64_t(groups - 1));
      x >>= bits_for(groups);
      const int column = int(x % uint64_t(columns));
      x >>= bits_for(columns);
      const int bank = int(x & uint64_t(per_group - 1));
      x >>= bits_for(per_group);
      const int row = int(x & ((uint64_t(1) << row_bits) - 1));
      for (int s = 0; s < splits; ++s) {
        const int c = column * splits + s;
        std::vector<int> vec = has_rank ? std::vector<int>{channel, 0, group, bank, row, c}
                                        : std::vector<int>{channel, group, bank, row, c};
        // The flat address too: the controller matches reads to buffered writes by it.
        entries.push_back({cycle, op == "WRITE", vec, int64_t(full) + int64_t(s) * tx});
      }
    }
  }
  if (entries.empty()) {
    std::fprintf(stderr, "%s: no requests\n", argv[2]);
    return 2;
  }
  std::vector<double> reads;
  double write_sum = 0;
  uint64_t writes = 0, clk = 0, done = 0, last = 0;
  std::vector<int> remaining(entries.size() / splits + 1, splits);
  size_t next = 0;
  while (done < entries.size()) {
    while (next < entries.size() && entries[next].cycle <= clk) {
      const Entry& e = entries[next];
      Ramulator::Request request(e.vec, e.write ? Ramulator::Request::Type::Write
                                                : Ramulator::Request::Type::Read);
      request.size_bytes = tx;
      request.addr = e.address;
      const uint64_t arrival = e.cycle;
      const size_t line = next / splits;
      const bool write = e.write;
      request.callback = [&, arrival, line, write](Ramulator::Request& r) {
        // Writes may come back posted, without a depart cycle: the current one then.
        const uint64_t depart = r.depart >= 0 ? uint64_t(r.depart) : clk;
        ++done;
        last = std::max(last, depart);
        if (--remaining[line] != 0) return;
        const double ns = (double(depart) - double(arrival)) * tck_ns;
        if (write) write_sum += ns, ++writes;
        else reads.push_back(ns);
      };
      if (!memory->send(request)) break;
      ++next;
    }
    memory->tick();
    ++clk;
  }
  frontend->finalize();
  memory->finalize();
  std::ostringstream stats;
  memory->print_stats(stats);
  std::sort(reads.begin(), reads.end());
  double sum = 0;
  for (double v : reads) sum += v;
  const auto percentile = [&](double f) {
    return reads.empty() ? 0.0 : reads[std::min(reads.size() - 1, size_t(f * double(reads.size())))];
  };
  const double lines = double(entries.size() / splits);
  const double span_ns = double(last - entries.front().cycle) * tck_ns;
  // Every row miss or conflict is an activate. Ramulator counts row hits of its
  // transactions: of lines only when a line is one transaction (with two, a line's
  // second half usually hits the row its first opened, which says nothing; the
  // activates tell the rows then).
  const double misses = stat_sum(stats.str(), "row_misses") + stat_sum(stats.str(), "row_conflicts");
  char hit_rate[64] = "";
  if (splits == 1)
    std::snprintf(hit_rate, sizeof hit_rate, "\"row_hit_rate\":%g,", stat_sum(stats.str(), "row_hits") / lines);
  std::printf(
      "{\"model\":\"ramulator2\",\"requests\":%.0f,\"bandwidth_gbs\":%g,\"read_latency_mean_ns\":%g,"
      "\"read_latency_p50_ns\":%g,\"read_latency_p99_ns\":%g,\"write_latency_mean_ns\":%g,"
      "%s\"activates\":%.0f,\"refreshes\":%.0f,\"end_ns\":%g}\n",
      lines, lines * 64.0 / span_ns, reads.empty() ? 0.0 : sum / double(reads.size()), percentile(0.5),
      percentile(0.99), writes ? write_sum / double(writes) : 0.0, hit_rate, misses,
      stat_sum(stats.str(), "num_maintenance_reqs_served"), double(last) * tck_ns);
  return 0;
}
