// rtsim dram-replay: feeds a DRAM request trace (dramsim3 format, as `simulate
// --dram-trace-out` writes it) to the cycle-level DRAM model alone, or to DRAMsim3
// through the same seam (--model dramsim3, in an rtsim built with it), and prints
// what docs/dram.md's "Checked against" tables compare. Requests enter in trace
// order, each at its cycle or, when its channel's queue is full, as soon as an
// entry frees (later requests wait behind it, as the cycle level's DRAM target and
// DRAMsim3's trace reader both do); latency counts from the trace cycle.
#include "cli_util.h"
#include "commands.h"

#include <rtsim/model/sim/dram.h>
#include <rtsim/model/sim/dram_reference.h>
#include <rtsim/model/sim/memory_trace.h>
#include <rtsim/workloads/error.h>

#include <nlohmann/json.hpp>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

namespace rtsim::cli {

namespace {

struct ReplayOptions {
  std::string trace, config = "desktop", model = "rtsim";
  bool untimed = false, print_ini = false;
};

void run_replay(const ReplayOptions& o) {
  sim::HardwareConfig hw = sim::load_hardware_config(o.config);
  if (o.model != "rtsim" && o.model != "dramsim3")
    throw InputError("--model", "unknown model '" + o.model + "' (rtsim | dramsim3)");
  sim::validate(hw);
  if (o.print_ini) {
    std::cout << sim::dramsim3_ini(hw.dram, hw.l2.line_bytes);
    return;
  }
  const std::vector<sim::DramTraceEntry> trace = sim::read_dramsim3_trace(o.trace);
  if (trace.empty()) throw InputError(o.trace, "holds no requests");
  const uint32_t line = hw.l2.line_bytes;
  sim::DramModel model(hw.dram, line);  // ours, or the reference's counts
  std::unique_ptr<sim::DramReference> reference;
  if (o.model == "dramsim3") {
    if (!sim::dramsim3_linked())
      throw InputError("--model", "dramsim3: this rtsim was built without DRAMsim3 (-DRTSIM_DRAMSIM3=DIR)");
    reference = sim::make_dramsim3(hw.dram, line,
                                   (std::filesystem::temp_directory_path() /
                                    ("rtsim-dram-replay-" + std::to_string(::getpid()))).string());
  }
  const uint64_t tck = hw.dram.tck_ps;
  std::vector<uint64_t> arrival(trace.size());
  std::vector<sim::DramCompletion> done;
  uint64_t end_ps = 0, completed = 0, now = 0;
  const auto collect = [&] {
    for (const auto& c : done) {
      end_ps = std::max(end_ps, c.done_ps);
      if (reference) model.count_reference_request(c.write, c.done_ps - arrival[c.tag]);
      ++completed;
    }
    done.clear();
  };
  const auto advance = [&](uint64_t t) {
    if (reference) reference->advance(t, done);
    else model.advance(t, done);
    collect();
  };
  const auto next = [&] { return reference ? reference->next_decision_ps() : model.next_decision_ps(); };
  for (size_t i = 0; i < trace.size(); ++i) {
    const sim::DramTraceEntry& e = trace[i];
    arrival[i] = o.untimed ? 0 : e.cycle * tck;
    now = std::max(now, arrival[i]);
    advance(now);
    for (;;) {
      const bool room = reference ? reference->can_accept(e.address, e.write) : model.can_accept(e.address);
      if (room) break;
      const uint64_t t = next();
      if (t == UINT64_MAX) throw std::runtime_error("dram-replay: a full queue with nothing to do");
      now = std::max(now, t);
      advance(now);
    }
    const sim::DramRequest r{e.address, arrival[i], i, e.write};
    if (reference) reference->enqueue(r, now);
    else model.enqueue(r, now);
  }
  while (completed < trace.size()) {
    const uint64_t t = next();
    if (t == UINT64_MAX) break;
    now = std::max(now, t);
    advance(now);
  }
  if (reference) reference->finish(end_ps, model);
  else model.settle(end_ps);
  const sim::DramModel::Counters& c = model.counters();
  const uint64_t first = arrival.front();
  const double span_ns = double(end_ps - first) / 1000.0;
  const uint64_t requests = c.reads + c.writes;
  nlohmann::json j;
  j["model"] = o.model;
  j["requests"] = requests;
  j["reads"] = c.reads;
  j["writes"] = c.writes;
  j["end_ns"] = double(end_ps) / 1000.0;
  j["bandwidth_gbs"] = span_ns > 0 ? double(c.bytes + c.bytes_written) / span_ns : 0.0;
  j["read_latency_mean_ns"] = c.reads ? double(c.read_latency_sum_ps) / 1000.0 / double(c.reads) : 0.0;
  j["read_latency_p50_ns"] = model.latency_percentile_ns(0.5, false);
  j["read_latency_p99_ns"] = model.latency_percentile_ns(0.99, false);
  j["write_latency_mean_ns"] = c.writes ? double(c.write_latency_sum_ps) / 1000.0 / double(c.writes) : 0.0;
  j["write_latency_p99_ns"] = model.latency_percentile_ns(0.99, true);
  j["write_latency_max_ns"] = double(c.write_latency_max_ps) / 1000.0;
  j["row_hit_rate"] = requests ? double(c.row_hits) / double(requests) : 0.0;
  j["activates"] = c.activates;
  j["refreshes"] = c.refreshes;
  j["bus_utilisation"] =
      span_ns > 0 ? double(c.bus_busy_ps) / 1000.0 / (span_ns * hw.dram.channels) : 0.0;
  j["queue_full_refusals"] = c.queue_full_refusals;
  std::cout << j.dump() << "\n";
}

}  // namespace

void add_dram_replay_command(CLI::App& root) {
  auto opts = std::make_shared<ReplayOptions>();
  CLI::App* cmd = root.add_subcommand(
      "dram-replay", "Replay a DRAM request trace (dramsim3 format) through the DRAM model alone; print JSON");
  cmd->add_option("--trace", opts->trace, "trace file (simulate --dram-trace-out)")->required();
  cmd->add_option("--config", opts->config, "hardware preset or TOML file: its [dram] keys")
      ->capture_default_str();
  cmd->add_option("--model", opts->model, "rtsim | dramsim3 (an rtsim built with -DRTSIM_DRAMSIM3=DIR)")
      ->capture_default_str();
  cmd->add_flag("--untimed", opts->untimed,
                "every request arrives at time 0: the trace goes in as fast as the queues take it");
  cmd->add_flag("--print-dramsim3-ini", opts->print_ini,
                "print the DRAMsim3 configuration written for --config's DRAM and stop");
  cmd->callback([opts] { run_replay(*opts); });
}

}  // namespace rtsim::cli
