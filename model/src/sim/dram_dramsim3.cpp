// dram.model = dramsim3: DRAMsim3 behind DramReference. Only its public header
// (dramsim3.h) is used, and only when rtsim was configured with -DRTSIM_DRAMSIM3=DIR
// (RTSIM_HAVE_DRAMSIM3); the .ini writer is always built so that tests check it.
#include <rtsim/model/sim/dram_reference.h>
#include <rtsim/model/sim/memory_trace.h>
#include <rtsim/workloads/error.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <deque>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unordered_map>

#ifdef RTSIM_HAVE_DRAMSIM3
#include <dramsim3.h>
#endif

namespace rtsim::sim {


bool dramsim3_linked() {
#ifdef RTSIM_HAVE_DRAMSIM3
  return true;
#else
  return false;
#endif
}

std::string dramsim3_ini(const DramConfig& d, uint32_t access_bytes) {
  // DRAMsim3's protocol for each of our parts; it has no LPDDR5.
  std::string protocol;
  if (d.part == "ddr4-2400") protocol = "DDR4";
  else if (d.part == "lpddr4-3200") protocol = "LPDDR4";
  else if (d.part == "gddr6") protocol = "GDDR6";
  else
    throw InputError("dram.model", "DRAMsim3 has no protocol for dram.part '" + d.part + "'");
  const DramBitFieldEncoder encoder(d, access_bytes);
  const std::string mapping = encoder.dramsim3_mapping();
  if (mapping.size() != 12)
    throw InputError("dram.model",
                     "DRAMsim3 needs every field, bankgroup included, in dram.address_mapping");
  // One DRAMsim3 transaction is bus_width / 8 x BL bytes and must be one of our
  // accesses (one L2 line): a device of device_width bits and BL such that
  // device_width x BL / 8 = access bytes, one device per channel. Its data bus is busy
  // burst_cycle = BL / 2 tCK (BL / 16 for GDDR6), which must be our tBURST.
  const uint32_t bursts = (access_bytes + d.burst_bytes - 1) / d.burst_bytes;
  const uint32_t tburst = bursts * d.burst_cycles;
  const uint32_t bl = protocol == "GDDR6" ? tburst * 16 : tburst * 2;
  const uint32_t width_bits = access_bytes * 8 / bl;
  if (width_bits == 0 || width_bits * bl != access_bytes * 8)
    throw InputError("dram.model", "DRAMsim3 cannot carry one " + std::to_string(access_bytes) +
                                       "-byte access in " + std::to_string(tburst) + " tCK");
  // Columns of device_width bits in one row; GDDR: DRAMsim3 multiplies them by BL.
  uint64_t columns = uint64_t(d.row_bytes) * 8 / width_bits;
  if (protocol == "GDDR6") columns /= bl;
  // Rows: as many as the address map's row field spans below 2^32 bytes a channel
  // (the rows of an 8 Gb device and more; DRAMsim3 masks the row field to them).
  const uint64_t rows = uint64_t(1) << 16;
  const uint64_t channel_mb =
      rows * d.row_bytes * d.banks * d.ranks / (uint64_t(1) << 20);
  const uint32_t channels = 1u << dram_field_bits(d.channels);
  const char* policy = d.page_policy == "closed" ? "CLOSE_PAGE" : "OPEN_PAGE";
  std::ostringstream s;
  s << "; written by rtsim (dramsim3_ini) for dram.part = " << d.part << "\n"
    << "[dram_structure]\nprotocol = " << protocol << "\nbankgroups = " << d.bank_groups
    << "\nbanks_per_group = " << d.banks_per_group() << "\nrows = " << rows << "\ncolumns = " << columns
    << "\ndevice_width = " << width_bits << "\nBL = " << bl << "\n\n[timing]\n";
  char tck[32];
  std::snprintf(tck, sizeof tck, "%.4f", d.tck_ps / 1000.0);
  s << "tCK = " << tck << "\nAL = 0\nCL = " << d.tcl << "\nCWL = " << d.tcwl << "\ntRCD = " << d.trcd
    << "\ntRCDRD = " << d.trcd << "\ntRCDWR = " << d.trcd_write << "\ntRP = " << d.trp
    << "\ntRAS = " << d.tras << "\ntRFC = " << d.trfc << "\ntREFI = " << d.trefi
    << "\ntRRD_S = " << d.trrd_s << "\ntRRD_L = " << d.trrd_l << "\ntWTR_S = " << d.twtr_s
    << "\ntWTR_L = " << d.twtr_l << "\ntFAW = " << d.tfaw << "\ntWR = " << d.twr << "\ntRTP = " << d.trtp
    << "\ntCCD_S = " << d.tccd_s << "\ntCCD_L = " << d.tccd_l << "\ntRTRS = " << d.trtrs
    // Not in our model: no precharge-to-precharge gap, no 32-activate window.
    << "\ntPPD = 0\nt32AW = " << 8 * d.tfaw << "\ntCKE = 6\ntCKESR = 7\ntXS = " << d.trfc + 12
    << "\ntXP = 8\n\n"
    << "[system]\nchannel_size = " << channel_mb << "\nchannels = " << channels
    << "\nbus_width = " << width_bits << "\naddress_mapping = " << mapping
    << "\nqueue_structure = PER_BANK\nrefresh_policy = RANK_LEVEL_STAGGERED\nrow_buf_policy = " << policy
    // DRAMsim3's own queues: a read queue and a write buffer of queue_entries each
    // (its default split; ours is one queue) and 8 commands per bank (its configs').
    << "\ncmd_queue_size = 8\ntrans_queue_size = " << d.queue_entries << "\n\n"
    << "[other]\nepoch_period = 2000000000\noutput_level = 0\n";
  return s.str();
}

#ifdef RTSIM_HAVE_DRAMSIM3

namespace {

class Dramsim3 final : public DramReference {
 public:
  Dramsim3(const DramConfig& config, uint32_t access_bytes, const std::string& dir)
      : tck_ps_(config.tck_ps), access_bytes_(access_bytes), encoder_(config, access_bytes),
        map_(config, access_bytes), dir_(dir) {
    std::filesystem::create_directories(dir);
    const std::string ini = (std::filesystem::path(dir) / "dramsim3.ini").string();
    std::ofstream(ini) << dramsim3_ini(config, access_bytes);
    memory_ = std::unique_ptr<dramsim3::MemorySystem>(dramsim3::GetMemorySystem(
        ini, dir, [this](uint64_t a) { done(a, false); }, [this](uint64_t a) { done(a, true); }));
  }

  bool can_accept(uint64_t address, bool write) const override {
    return memory_->WillAcceptTransaction(encoder_.encode(map_.decode(address)), write);
  }

  void enqueue(const DramRequest& r, uint64_t now_ps) override {
    tick_to(now_ps, nullptr);  // the cycles before it could take part
    const uint64_t a = encoder_.encode(map_.decode(r.address));
    memory_->AddTransaction(a, r.write);
    waiting_[key(a, r.write)].push_back(r);
    ++outstanding_;
  }

  void advance(uint64_t now_ps, std::vector<DramCompletion>& out) override {
    out.insert(out.end(), early_.begin(), early_.end());
    early_.clear();
    // Cycle clk_ happens at clk_ x tCK: every cycle up to now_ps.
    while (outstanding_ > 0 && clk_ * tck_ps_ <= now_ps) tick(&out);
  }

  uint64_t next_decision_ps() const override {
    return outstanding_ > 0 || !early_.empty() ? clk_ * tck_ps_ : UINT64_MAX;
  }

  void finish(uint64_t, DramModel& counts) override {
    memory_->PrintStats();
    std::ifstream in(std::filesystem::path(dir_) / "dramsim3.json");
    const nlohmann::json j = nlohmann::json::parse(in);
    uint64_t hits = 0, acts = 0, pres = 0, refs = 0, columns = 0;
    std::vector<std::pair<uint64_t, uint64_t>> writes;  // its write_latency histogram, cycles
    for (const auto& [channel, c] : j.items()) {
      if (c.contains("write_latency") && c["write_latency"].is_object())
        for (const auto& [cycles, count] : c["write_latency"].items())
          writes.emplace_back(std::stoull(cycles) * tck_ps_, count.get<uint64_t>());
      hits += c.value("num_read_row_hits", uint64_t(0)) + c.value("num_write_row_hits", uint64_t(0));
      acts += c.value("num_act_cmds", uint64_t(0));
      pres += c.value("num_pre_cmds", uint64_t(0));
      refs += c.value("num_ref_cmds", uint64_t(0));
      columns += c.value("num_read_cmds", uint64_t(0)) + c.value("num_write_cmds", uint64_t(0));
    }
    counts.set_reference_commands(hits, acts, pres, refs, columns * counts.transfer_ps());
    counts.set_reference_write_latencies(writes);
  }

 private:
  static uint64_t key(uint64_t address, bool write) { return address << 1 | uint64_t(write); }
  void tick(std::vector<DramCompletion>* out) {
    sink_ = out;
    memory_->ClockTick();
    sink_ = nullptr;
    ++clk_;
  }
  void tick_to(uint64_t now_ps, std::vector<DramCompletion>* out) {
    const uint64_t cycle = (now_ps + tck_ps_ - 1) / tck_ps_;
    while (clk_ < cycle) tick(out ? out : &early_);
  }
  void done(uint64_t address, bool write) {
    auto it = waiting_.find(key(address, write));
    if (it == waiting_.end() || it->second.empty()) return;  // not ours (cannot happen)
    const DramRequest r = it->second.front();
    it->second.pop_front();
    --outstanding_;
    DramCompletion c;
    c.tag = r.tag;
    c.done_ps = clk_ * tck_ps_;
    c.write = write;
    (sink_ ? *sink_ : early_).push_back(c);
  }

  uint64_t tck_ps_;
  uint32_t access_bytes_;
  DramBitFieldEncoder encoder_;
  DramAddressMap map_;
  std::string dir_;
  std::unique_ptr<dramsim3::MemorySystem> memory_;
  uint64_t clk_ = 0, outstanding_ = 0;
  std::unordered_map<uint64_t, std::deque<DramRequest>> waiting_;  // FIFO per address
  std::vector<DramCompletion>* sink_ = nullptr;
  std::vector<DramCompletion> early_;  // completed while catching up in enqueue
};

}  // namespace

std::unique_ptr<DramReference> make_dramsim3(const DramConfig& config, uint32_t access_bytes,
                                             const std::string& work_dir) {
  return std::make_unique<Dramsim3>(config, access_bytes, work_dir);
}

#else

std::unique_ptr<DramReference> make_dramsim3(const DramConfig&, uint32_t, const std::string&) {
  throw InputError("dram.model",
                   "dramsim3: this rtsim was built without DRAMsim3 (configure with -DRTSIM_DRAMSIM3=DIR)");
}

#endif

}  // namespace rtsim::sim
