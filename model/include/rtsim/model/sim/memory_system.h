#pragma once
// The memory hierarchy of the functional and loosely-timed levels, as machine.h
// describes it: one L1 node cache per TRV unit, one L1 triangle cache per IST
// unit, a crossbar to the L2 slices, DRAM.
//  - FunctionalMemory: direct calls, tags and counts only, no time.
//  - LtCache / LtDram: SystemC modules behind TLM-2.0 sockets (blocking transport).
//    A cache serves a request at its next free port slot, a hit after its hit
//    latency, a read miss when the next level's data is there plus its fill
//    latency; reads of a line still on its way merge and wait for it. Dirty lines
//    that leave are written to the next level (posted). LtDram answers each
//    request in arrival order from its bank, bus and refresh state (DramModel).
//    Any other TLM-2.0 LT target can stand in for LtDram (or for the whole hierarchy).
// Both walk the same CacheModel objects, so their counts follow one definition.
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/model/sim/dram.h>
#include <rtsim/model/sim/machine.h>
#include <rtsim/model/sim/ray_engine.h>
#include <rtsim/model/sim/ray_probe.h>

#include <systemc>
#include <tlm>
#include <tlm_utils/multi_passthrough_initiator_socket.h>
#include <tlm_utils/multi_passthrough_target_socket.h>
#include <tlm_utils/simple_initiator_socket.h>
#include <tlm_utils/tlm_quantumkeeper.h>

#include <functional>
#include <memory>
#include <queue>
#include <vector>

namespace rtsim::sim {

// Carried by every TLM-2.0 payload of the model: what the bytes are and for whom.
struct AccessExtension : tlm::tlm_extension<AccessExtension> {
  AccessKind kind = AccessKind::Node;
  RayType ray_type = RayType::Primary;
  uint64_t token = 0;  // the requester's id for the response (cycle level)
  uint64_t first_try_ps = 0;  // when the requester first tried to send it (DRAM latency)
  int crossbar_port = 0;      // cycle level: the crossbar port the request came in on
  // A read an L1 sends down on a miss: the unit that waits for it (its accounting) and
  // where the read is now (UnitAccounting::AtNoc, AtL2 or AtDram); null otherwise.
  UnitAccounting* owner = nullptr;
  UnitAccounting::Counter location = UnitAccounting::AtNoc;
  ServedBy served = ServedBy::None;  // the level that answered (set on the way back)
  uint32_t probe_request = 0;        // the probed ray's request number + 1; 0: another ray's
  tlm::tlm_extension_base* clone() const override { return new AccessExtension(*this); }
  void copy_from(const tlm::tlm_extension_base& other) override {
    *this = static_cast<const AccessExtension&>(other);
  }
};

// The read `e` carries moves to `to` at `at` in its owner's accounting (no owner: a
// write, or nobody's miss); end_read: it is back at its L1.
inline void move_read(AccessExtension& e, uint64_t now, uint64_t at, UnitAccounting::Counter to) {
  if (!e.owner) return;
  e.owner->move(now, at, e.location, to);
  e.location = to;
}
inline void end_read(AccessExtension& e, uint64_t now, uint64_t at) {
  if (!e.owner) return;
  e.owner->change(now, at, e.location, -1);
  e.owner = nullptr;
}

// The DRAM's answer as a level that served a read.
inline ServedBy served_by_dram(RowOutcome outcome) {
  switch (outcome) {
    case RowOutcome::Hit: return ServedBy::DramRowHit;
    case RowOutcome::Closed: return ServedBy::DramRowMiss;
    case RowOutcome::Conflict: return ServedBy::DramRowConflict;
  }
  return ServedBy::Dram;
}

// Reusable read payloads, each owning one AccessExtension. Every payload the
// cycle-level units exchange comes from a pool, so they reach its extension
// through the pool's own record of it (inline) rather than the library's lookup by
// extension id (a call per access); the extension is attached all the same, for
// any other TLM-2.0 module that reads it.
class PayloadPool {
 public:
  PayloadPool() = default;
  PayloadPool(const PayloadPool&) = delete;
  PayloadPool& operator=(const PayloadPool&) = delete;
  ~PayloadPool();
  tlm::tlm_generic_payload* get() {
    if (free_.empty()) grow();
    tlm::tlm_generic_payload* p = free_.back();
    free_.pop_back();
    return p;
  }
  void put(tlm::tlm_generic_payload* p) { free_.push_back(p); }
  // A payload for a unit's line request: a read or write of `line`, its extension
  // naming the kind, ray type, the unit's token and the probed request (0: none).
  tlm::tlm_generic_payload* request(const LineAccess& line, RayType type, uint64_t token,
                                    uint32_t probe_request) {
    tlm::tlm_generic_payload* p = get();
    AccessExtension& ext = extension(*p);
    ext.kind = line.kind, ext.ray_type = type, ext.token = token;
    ext.probe_request = probe_request;  // pooled payloads: never stale
    p->set_command(line.write ? tlm::TLM_WRITE_COMMAND : tlm::TLM_READ_COMMAND);
    p->set_address(line.line);
    p->set_data_length(line.bytes);
    return p;
  }
  // p must come from a PayloadPool.
  static AccessExtension& extension(tlm::tlm_generic_payload& p) {
    return *static_cast<Pooled&>(p).access;
  }

 private:
  void grow();  // one more payload in the pool
  struct Pooled : tlm::tlm_generic_payload {
    AccessExtension* access = nullptr;  // owned by the payload, which frees it
  };
  std::vector<tlm::tlm_generic_payload*> free_, all_;
};

class FunctionalMemory final : public MemoryPort {
 public:
  // texture_caches: build each IST unit's L1 texture cache (a scene with
  // alpha-tested materials, whose any-hit stage reads through it).
  explicit FunctionalMemory(const HardwareConfig& config, bool texture_caches = false);
  // Inline (below): the functional level's engine calls it for every line.
  uint64_t access(Requester who, uint32_t unit, const LineAccess& access, uint64_t issue_ps) override {
    return serve<false>(who, unit, access, issue_ps, nullptr);
  }
  uint64_t access_probed(Requester who, uint32_t unit, const LineAccess& access, uint64_t issue_ps,
                         ServedBy* served) override {
    return serve<true>(who, unit, access, issue_ps, served);
  }
  uint32_t line_bytes(Requester who) const override;
  void reset_counters();

  MachineShape shape;
  std::vector<std::unique_ptr<CacheModel>> l1_node, l1_triangle, l2;  // l2: its slices
  std::vector<std::unique_ptr<CacheModel>> l1_texture;  // per IST unit; empty unless built
  Crossbar noc;
  DramModel dram;

 private:
  template <bool kProbed>
  uint64_t serve(Requester who, uint32_t unit, const LineAccess& access, uint64_t issue_ps, ServedBy* served);
  bool to_l2(uint32_t core, const LineAccess& access);  // true: the L2 hit
  uint32_t texture_line_bytes_ = 64;
};

template <bool kProbed>
inline uint64_t FunctionalMemory::serve(Requester who, uint32_t unit, const LineAccess& a,
                                        uint64_t issue_ps, ServedBy* served) {
  const bool trv = who == Requester::Trv;
  CacheModel& l1 = *(trv ? l1_node : who == Requester::Ist ? l1_triangle : l1_texture)[unit];
  const CacheModel::Result r = l1.access(a);
  if constexpr (kProbed) *served = a.write ? ServedBy::L1Write : ServedBy::L1Hit;
  if (!r.writeback.dirty && !r.fetch) return issue_ps;  // a hit: nothing goes to the L2
  const uint32_t core = trv ? shape.core_of_trv(unit) : shape.core_of_ist(unit);
  const uint32_t l1_line = l1.config().line_bytes;
  const CacheModel& slices = *l2.front();
  if (r.writeback.dirty)
    to_l2(core, {slices.line_of(r.writeback.line), l1_line, AccessKind::Stack, r.writeback.writer, true});
  if (r.fetch) {
    const bool l2_hit = to_l2(core, {slices.line_of(a.line), l1_line, a.kind, a.ray_type, false});
    if constexpr (kProbed) *served = l2_hit ? ServedBy::L2Hit : ServedBy::Dram;
  }
  return issue_ps;
}

// The functional hierarchy fed by the core's accesses as one TRV and one IST
// unit would send them (one request per line and step): what `rtsim trace`
// measures, with one ray in flight.
// With a probe: every request is also the probed ray's (trace --trace-ray feeds it
// that ray alone).
class FunctionalMemorySink : public AccessSink {
 public:
  explicit FunctionalMemorySink(FunctionalMemory& memory, RayProbe* probe = nullptr)
      : memory_(&memory), probe_(probe) {}
  void on_access(const MemoryAccess& access, RayType ray_type) override;
  void on_step_end() override;

 private:
  FunctionalMemory* memory_;
  RayProbe* probe_;
  std::vector<LineAccess> lines_;  // this step's, in order
  std::vector<MemoryAccess> accesses_;  // this step's (probed)
};

class LtCache : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<LtCache> target;
  tlm_utils::simple_initiator_socket<LtCache> next;
  LtCache(sc_core::sc_module_name name, const CacheConfig& config, uint64_t cycle_ps);
  CacheModel model;
  // Level 1 (a unit's L1: its misses are `unit`'s reads, for its accounting) or 2.
  void set_level(int level, UnitAccounting* unit = nullptr) { level_ = level, unit_ = unit; }
  void draw_on(Timeline* timeline, uint32_t track) { timeline_ = timeline, track_ = track; }

 private:
  int level_ = 2;
  UnitAccounting* unit_ = nullptr;
  Timeline* timeline_ = nullptr;
  uint32_t track_ = 0;
  void b_transport(int id, tlm::tlm_generic_payload& payload, sc_core::sc_time& delay);
  tlm::tlm_generic_payload writeback_;  // owns its AccessExtension
  AccessExtension* writeback_extension_;
  // When the misses now outstanding land (at most config.mshrs): a miss that finds
  // them all busy goes down when the earliest frees, as at the cycle level.
  std::priority_queue<uint64_t, std::vector<uint64_t>, std::greater<uint64_t>> mshr_free_;
};

// The crossbar at the loosely-timed level: L1s bind to `target` (bind_l1 records
// each port's core), `to_slice[s]` goes to L2 slice s. A request's delay grows by
// its way to the slice, the answer's by its way back (Crossbar).
class LtCrossbar : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<LtCrossbar> target;
  tlm_utils::multi_passthrough_initiator_socket<LtCrossbar> to_slice;
  LtCrossbar(sc_core::sc_module_name name, Crossbar& model, const MachineShape& shape);
  void bind_l1(tlm_utils::simple_initiator_socket<LtCache>& l1, uint32_t core);

 private:
  void b_transport(int id, tlm::tlm_generic_payload& payload, sc_core::sc_time& delay);
  Crossbar& model_;
  MachineShape shape_;
  std::vector<uint32_t> core_of_port_;
};

class LtDram : public sc_core::sc_module {
 public:
  tlm_utils::multi_passthrough_target_socket<LtDram> target;
  LtDram(sc_core::sc_module_name name, const DramConfig& config, uint32_t access_bytes);
  DramModel model;

 private:
  void b_transport(int id, tlm::tlm_generic_payload& payload, sc_core::sc_time& delay);
};

// The loosely-timed top level: the ray engine in one SC_THREAD, its accesses sent
// by blocking transport through per-unit initiator sockets, the quantum keeper
// deciding when the thread yields to the kernel.
class LtSystem : public sc_core::sc_module, public MemoryPort {
 public:
  LtSystem(sc_core::sc_module_name name, const HardwareConfig& config, const Workload& workload,
           std::function<void(uint64_t)> progress);
  uint64_t access(Requester who, uint32_t unit, const LineAccess& access, uint64_t issue_ps) override;
  uint64_t access_probed(Requester who, uint32_t unit, const LineAccess& access, uint64_t issue_ps,
                         ServedBy* served) override;
  uint32_t line_bytes(Requester who) const override;
  void reset_counters();

  RayEngine engine;
  std::vector<FrameFigures> frame_history;
  MachineShape shape;
  Crossbar noc_model;
  std::vector<std::unique_ptr<LtCache>> l1_node, l1_triangle, l2;  // l2: its slices
  std::vector<std::unique_ptr<LtCache>> l1_texture;  // per IST unit, alpha-tested scenes only
  std::unique_ptr<LtCrossbar> noc;
  std::unique_ptr<LtDram> dram;

 private:
  SC_HAS_PROCESS(LtSystem);
  void thread();
  HardwareConfig config_;
  std::function<void(uint64_t)> progress_;
  std::vector<std::unique_ptr<tlm_utils::simple_initiator_socket<LtSystem>>> trv_ports_, ist_ports_, texture_ports_;
  tlm_utils::tlm_quantumkeeper quantum_;
  tlm::tlm_generic_payload payload_;  // owns its AccessExtension
  AccessExtension* extension_;
  uint8_t buffer_[4096] = {};
};

}  // namespace rtsim::sim
