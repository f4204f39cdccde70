#pragma once
// The machine as data: what instances a HardwareConfig describes, how they are
// numbered and named, and how they connect. Every fidelity level builds its
// units, caches and crossbar from this one description, and every statistic is
// reported under the instance name it gives:
//
//   accelerator (clock_mhz)
//     core<c>            c < cores: raygen, shading,
//       trv<u>, l1_node<u>        u < trv.units (a TRV unit and its L1 node cache)
//       ist<i>, l1_triangle<i>    i < ist.units (an IST unit and its L1 triangle cache)
//       l1_texture<i>             the IST unit's L1 texture cache, which its any-hit
//                                 stage reads through (alpha-tested scenes only)
//     noc                a crossbar: every core's L1s to every L2 slice
//     l2.slice<s>        s < l2.slices, line index mod slices
//     dram               dram.channels channels behind the slices
//
// Units are numbered globally core-major (TRV unit g = c * trv.units + u), so a
// one-core machine keeps the numbers it always had. A TRV unit sends leaves to
// the IST unit u mod ist.units of its own core.
#include <rtsim/model/sim/config.h>
#include <rtsim/model/sim/port_slots.h>
#include <rtsim/model/sim/stats.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim::sim {

class Timeline;

// Host memory the model of machine `c` needs before its first ray, from the
// configuration alone: cache tags (kCacheLineHostBytes a line: tag, LRU clock,
// arrival time, dirty flag) of every L1 (one per TRV / IST unit of every core) and
// of the L2, and the ray slots (cores x trv.units x trv.ray_slots). `factors`
// gets the largest term written with its keys, for a refusal's message.
constexpr uint64_t kCacheLineHostBytes = 25;
uint64_t model_memory_bytes(const HardwareConfig& c, std::string* factors = nullptr);

struct MachineShape {
  uint32_t cores = 1;
  uint32_t trv_per_core = 1, ist_per_core = 1, slots_per_trv = 1;
  uint32_t l2_slices = 1;
  uint32_t l2_line_bytes = 64;

  static MachineShape of(const HardwareConfig& config);

  uint32_t trv_units() const { return cores * trv_per_core; }
  uint32_t ist_units() const { return cores * ist_per_core; }
  uint32_t slots() const { return trv_units() * slots_per_trv; }
  uint32_t core_of_trv(uint32_t trv) const { return trv / trv_per_core; }
  uint32_t core_of_ist(uint32_t ist) const { return ist / ist_per_core; }
  uint32_t ist_of_trv(uint32_t trv) const {
    return core_of_trv(trv) * ist_per_core + (trv % trv_per_core) % ist_per_core;
  }
  uint32_t slice_of(uint64_t address) const {
    return l2_slices == 1 ? 0 : uint32_t((address / l2_line_bytes) % l2_slices);
  }

  // Instance names, as the statistics use them.
  static std::string core_name(uint32_t core) { return "core" + std::to_string(core); }
  std::string trv_name(uint32_t trv) const;          // core1.trv2
  std::string ist_name(uint32_t ist) const;          // core1.ist0
  std::string l1_node_name(uint32_t trv) const;      // core1.l1_node2
  std::string l1_triangle_name(uint32_t ist) const;  // core1.l1_triangle0
  std::string l1_texture_name(uint32_t ist) const;   // core1.l1_texture0
  static std::string slice_name(uint32_t slice) { return "l2.slice" + std::to_string(slice); }
  // The same with '_' for '.' (SystemC module names may not hold dots).
  static std::string module_name(const std::string& instance);
};

// The crossbar between the cores' L1s and the L2 slices. Each core and each
// slice has one port each way; a message of header + data bytes takes
// ceil(bytes / flit_bytes) flits, each in the first cycle from its send time on
// in which both the sender's outgoing and the receiver's incoming port are free
// (PortSlots: reservations made out of time order, as the lt level makes them,
// still find the cycles free at their own time; no head-of-line blocking, as
// with virtual output queues), then latency_cycles to arrive. Reads send a header and get the line
// back; writes send the line and get a header back. flit_bytes = 0 is an ideal
// crossbar: no serialisation, only the latency. One definition of the counts
// for every level; the functional level counts without time.
class Crossbar {
 public:
  Crossbar(const HardwareConfig& config, const MachineShape& shape, bool timed);

  // When a request of `data_bytes` (0 for a read) sent at t_ps reaches the slice.
  uint64_t to_slice(uint32_t core, uint32_t slice, uint32_t data_bytes, uint64_t t_ps);
  // When the response (`data_bytes`: the line for a read, 0 for a write) reaches the core.
  uint64_t to_core(uint32_t slice, uint32_t core, uint32_t data_bytes, uint64_t t_ps);

  void reset_counters();
  // Draws every message, from its send to its arrival, on a track per receiving port:
  // requests on to_slice[slice], answers on to_core[core] (timed levels).
  void draw_on(Timeline* timeline, std::vector<uint32_t> to_slice, std::vector<uint32_t> to_core) {
    timeline_ = timeline, slice_tracks_ = std::move(to_slice), core_tracks_ = std::move(to_core);
  }
  // noc.*: messages, bytes and flits each way, port utilisation, queueing.
  void report(StatsRegistry& stats, const std::string& prefix, uint64_t simulated_ps) const;
  uint64_t bytes() const { return bytes_[0] + bytes_[1]; }

 private:
  // out and in are null without port timing (untimed, or an ideal crossbar).
  uint64_t send(PortSlots* out, PortSlots* in, uint32_t to, uint32_t data_bytes, uint64_t t_ps,
                int direction);

  bool timed_;
  uint32_t flit_bytes_, header_bytes_;
  uint64_t cycle_ps_, latency_ps_;
  // Each port's taken cycles.
  std::vector<PortSlots> core_out_, slice_in_, slice_out_, core_in_;
  std::vector<uint64_t> core_in_flits_, slice_in_flits_;  // busy flit-cycles per receiving port
  uint64_t messages_[2] = {}, bytes_[2] = {}, flits_[2] = {};
  uint64_t wait_ps_ = 0, wait_max_ps_ = 0;
  Timeline* timeline_ = nullptr;
  std::vector<uint32_t> slice_tracks_, core_tracks_;
};

}  // namespace rtsim::sim
