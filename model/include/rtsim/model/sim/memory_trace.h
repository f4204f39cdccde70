#pragma once
// Request traces of the memory hierarchy, so that models nobody here wrote can
// replay what ours saw (docs/dram.md "Checked against"):
// - a DRAM trace: every request that reaches the DRAM, in the order it reaches it,
//   in a format a reference simulator reads (DramTraceFormat);
// - a cache trace: every access entering one cache (all its instances), with our
//   outcome, so that another cache model can be fed the same stream and compared.
// `rtsim simulate --dram-trace-out / --cache-trace-out` write them.
#include <rtsim/model/sim/cache_model.h>
#include <rtsim/model/sim/dram.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace rtsim::sim {

// dramsim3: "0x<address> READ|WRITE <cycle>" per line, DRAMsim3's trace format (its
//   TraceBasedCPU reads it). cycle: the DRAM clock edge (tCK) at or after the
//   request's first try. The address is the request's decoded location re-encoded
//   with every field as a bit field in our mapping's order (the channel count rounded
//   up to a power of two), so that a reference with bit-field mapping (DRAMsim3's
//   address_mapping "rorabacobgch" for our default) finds the same channel, rank,
//   bank group, bank, row and column. For power-of-two channel counts it is the
//   request's address.
// ramulator2: "R|W <channel>,<rank>,<bankgroup>,<bank>,<row>,<column>" per line,
//   Ramulator 2's ReadWriteTrace (an address vector in its DDR4/LPDDR5 level order;
//   bank within its group, column in accesses of one L2 line). It has no time:
//   Ramulator 2 sends the requests as fast as its queues take them.
enum class DramTraceFormat : uint8_t { Dramsim3, Ramulator2 };
// Throws InputError naming --dram-trace-format.
DramTraceFormat parse_dram_trace_format(const std::string& name);

// The re-encoded address of the dramsim3 format (see above).
class DramBitFieldEncoder {
 public:
  DramBitFieldEncoder(const DramConfig& config, uint32_t access_bytes);
  uint64_t encode(const DramAddress& where) const;
  // DRAMsim3's address_mapping string for the same field order, e.g. "rorabacobgch";
  // without a bankgroup field the group is the bank's top bits, which DRAMsim3 cannot
  // say: empty then.
  std::string dramsim3_mapping() const;

 private:
  struct Field {
    char which;  // r row, k rank, b bank, g bank group, c column, h channel
    uint32_t bits;
  };
  std::vector<Field> fields_;  // least significant first
  uint32_t offset_bits_;
  uint32_t banks_per_group_;
  bool group_field_ = false;
};

// Writes a DRAM trace; opened before the simulation so that a bad path costs
// nothing. Throws InputError(flag, ...) when the file cannot be written.
class DramTraceWriter {
 public:
  DramTraceWriter(const std::string& path, DramTraceFormat format, const DramConfig& config,
                  uint32_t access_bytes, const std::string& flag = "--dram-trace-out");
  ~DramTraceWriter();
  DramTraceWriter(const DramTraceWriter&) = delete;
  DramTraceWriter& operator=(const DramTraceWriter&) = delete;
  void write(const DramRequestRecord& record);
  void close();  // flushes; throws InputError(flag, ...) if writing failed
  uint64_t records() const { return records_; }

 private:
  std::string path_, flag_;
  DramTraceFormat format_;
  DramBitFieldEncoder encoder_;
  uint64_t tck_ps_;
  uint32_t banks_per_group_;
  std::FILE* file_ = nullptr;
  uint64_t records_ = 0;
};

// One line of a dramsim3-format trace.
struct DramTraceEntry {
  uint64_t cycle = 0;
  uint64_t address = 0;
  bool write = false;
};
// Reads a dramsim3-format trace strictly (InputError "<path>:<line>: reason").
std::vector<DramTraceEntry> read_dramsim3_trace(const std::string& path);

// Cache traces: "# rtsim cache trace 1" and "# key value" header lines (cache,
// instances, size_bytes, line_bytes, associativity, interleave, policy), then per
// access "<instance> R|W 0x<line address> hit|miss|merge", and (one frame) a last
// "# writebacks N".
const std::vector<std::string>& cache_trace_names();  // l1_node, l1_triangle, l2
class CacheTraceWriter {
 public:
  // Throws InputError(flag, ...) when the file cannot be written.
  CacheTraceWriter(const std::string& path, const std::string& cache, const std::string& flag);
  ~CacheTraceWriter();
  CacheTraceWriter(const CacheTraceWriter&) = delete;
  CacheTraceWriter& operator=(const CacheTraceWriter&) = delete;
  // Before the first access: the header, from instance 0's configuration.
  void header(const CacheConfig& config, uint32_t instances);
  void write(uint32_t instance, const LineAccess& access, CacheModel::Outcome outcome);
  // After the last access: "# writebacks N", the dirty lines the instances evicted.
  void footer(uint64_t writebacks);
  void close();
  const std::string& cache() const { return cache_; }

 private:
  std::string path_, cache_, flag_;
  std::FILE* file_ = nullptr;
};

}  // namespace rtsim::sim
