#include <rtsim/model/sim/memory_trace.h>
#include <rtsim/workloads/error.h>
#include <rtsim/workloads/numbers.h>

#include <unistd.h>

#include <algorithm>
#include <cinttypes>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace rtsim::sim {

namespace {

// A trace is streamed during the run to a temporary name beside `path` (as the
// timeline is) and renamed into place once complete, so a failed or killed run never
// leaves a half-written trace under the name asked for.
std::string partial_name(const std::string& path) { return path + ".tmp-" + std::to_string(::getpid()); }

std::FILE* open_for_writing(const std::string& path, const std::string& flag) {
  if (path.empty()) throw InputError(flag, "needs a file name");
  std::FILE* f = std::fopen(partial_name(path).c_str(), "w");
  if (!f) throw InputError(flag, "cannot write '" + path + "'");
  return f;
}

void close_checked(std::FILE*& f, const std::string& path, const std::string& flag) {
  if (!f) return;
  const bool bad = std::ferror(f) != 0;
  const bool closed = std::fclose(f) == 0;
  f = nullptr;
  std::error_code ec;
  if (!bad && closed) std::filesystem::rename(partial_name(path), path, ec);
  if (bad || !closed || ec) {
    std::filesystem::remove(partial_name(path), ec);
    throw InputError(flag, "writing '" + path + "' failed");
  }
}

// A writer destroyed before close() (the run failed): its partial file goes.
void discard(std::FILE*& f, const std::string& path) {
  if (!f) return;
  std::fclose(f);
  f = nullptr;
  std::error_code ec;
  std::filesystem::remove(partial_name(path), ec);
}
}  // namespace

DramTraceFormat parse_dram_trace_format(const std::string& name) {
  if (name == "dramsim3") return DramTraceFormat::Dramsim3;
  if (name == "ramulator2") return DramTraceFormat::Ramulator2;
  throw InputError("--dram-trace-format", "unknown format '" + name + "' (dramsim3 | ramulator2)");
}

// ------------------------------------------------------------ bit-field encoder

DramBitFieldEncoder::DramBitFieldEncoder(const DramConfig& c, uint32_t access_bytes)
    : offset_bits_(dram_field_bits(access_bytes)) {
  const uint32_t groups = std::max<uint32_t>(1, c.bank_groups);
  banks_per_group_ = std::max<uint32_t>(1, c.banks / groups);
  const std::vector<std::string> names = dram_mapping_fields(c.address_mapping);
  group_field_ = std::find(names.begin(), names.end(), "bankgroup") != names.end();
  // The same fields as DramAddressMap, each as wide as its range needs; a row field
  // below others keeps the map's 2^24 rows.
  for (auto it = names.rbegin(); it != names.rend(); ++it) {
    Field f{};
    if (*it == "row") f = {'r', it + 1 == names.rend() ? 0u : 24u};
    else if (*it == "rank") f = {'k', dram_field_bits(c.ranks)};
    else if (*it == "bank") f = {'b', dram_field_bits(group_field_ ? banks_per_group_ : c.banks)};
    else if (*it == "bankgroup") f = {'g', dram_field_bits(groups)};
    else if (*it == "column") f = {'c', dram_field_bits(std::max<uint64_t>(1, c.row_bytes / access_bytes))};
    else if (*it == "channel") f = {'h', dram_field_bits(c.channels)};
    else throw InputError("dram.address_mapping", "unknown field '" + *it + "'");
    fields_.push_back(f);
  }
}

uint64_t DramBitFieldEncoder::encode(const DramAddress& w) const {
  uint64_t out = 0;
  uint32_t shift = offset_bits_;
  for (const Field& f : fields_) {
    uint64_t v = 0;
    switch (f.which) {
      case 'r': v = w.row; break;
      case 'k': v = w.rank; break;
      case 'b': v = group_field_ ? w.bank % banks_per_group_ : w.bank; break;
      case 'g': v = w.bank_group; break;
      case 'c': v = w.column; break;
      case 'h': v = w.channel; break;
    }
    if (shift < 64) out |= v << shift;
    shift += f.bits;
  }
  return out;
}

std::string DramBitFieldEncoder::dramsim3_mapping() const {
  if (!group_field_) return "";
  std::string out;
  for (auto it = fields_.rbegin(); it != fields_.rend(); ++it) {
    switch (it->which) {
      case 'r': out += "ro"; break;
      case 'k': out += "ra"; break;
      case 'b': out += "ba"; break;
      case 'g': out += "bg"; break;
      case 'c': out += "co"; break;
      case 'h': out += "ch"; break;
    }
  }
  return out;
}

// ------------------------------------------------------------------ DRAM trace

DramTraceWriter::DramTraceWriter(const std::string& path, DramTraceFormat format,
                                 const DramConfig& config, uint32_t access_bytes,
                                 const std::string& flag)
    : path_(path), flag_(flag), format_(format), encoder_(config, access_bytes),
      tck_ps_(config.tck_ps), banks_per_group_(std::max<uint32_t>(1, config.banks_per_group())) {
  file_ = open_for_writing(path, flag);
}

DramTraceWriter::~DramTraceWriter() { discard(file_, path_); }

void DramTraceWriter::write(const DramRequestRecord& r) {
  ++records_;
  if (format_ == DramTraceFormat::Dramsim3) {
    // The clock edge at or after the first try: the first cycle the controller could see it.
    const uint64_t cycle = (r.time_ps + tck_ps_ - 1) / tck_ps_;
    std::fprintf(file_, "0x%" PRIx64 " %s %" PRIu64 "\n", encoder_.encode(r.where),
                 r.write ? "WRITE" : "READ", cycle);
    return;
  }
  const DramAddress& w = r.where;
  std::fprintf(file_, "%s %u,%u,%u,%u,%" PRIu64 ",%u\n", r.write ? "W" : "R", w.channel, w.rank,
               w.bank_group, w.bank % banks_per_group_, w.row, w.column);
}

void DramTraceWriter::close() { close_checked(file_, path_, flag_); }

namespace {
bool parse_hex(const std::string& text, uint64_t& out) {
  if (text.size() < 3 || text[0] != '0' || (text[1] != 'x' && text[1] != 'X') || text.size() > 18)
    return false;
  out = 0;
  for (size_t i = 2; i < text.size(); ++i) {
    const char c = text[i];
    int d;
    if (c >= '0' && c <= '9') d = c - '0';
    else if (c >= 'a' && c <= 'f') d = c - 'a' + 10;
    else if (c >= 'A' && c <= 'F') d = c - 'A' + 10;
    else return false;
    out = out << 4 | uint64_t(d);
  }
  return true;
}
}  // namespace

std::vector<DramTraceEntry> read_dramsim3_trace(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "cannot read the trace");
  std::vector<DramTraceEntry> out;
  std::string line;
  uint64_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string where = path + ":" + std::to_string(number);
    std::istringstream fields(line);
    std::string address, op, cycle, extra;
    if (!(fields >> address >> op >> cycle) || (fields >> extra))
      throw InputError(where, "expected '0x<address> READ|WRITE <cycle>'");
    DramTraceEntry e;
    if (!parse_hex(address, e.address)) throw InputError(where, "address '" + address + "' is not 0x<hex>");
    if (op == "READ") e.write = false;
    else if (op == "WRITE") e.write = true;
    else throw InputError(where, "operation '" + op + "' is not READ or WRITE");
    e.cycle = read_unsigned(cycle, 0, UINT64_MAX / 2, where + ": cycle");
    out.push_back(e);
  }
  return out;
}

// ----------------------------------------------------------------- cache trace

const std::vector<std::string>& cache_trace_names() {
  static const std::vector<std::string> names = {"l1_node", "l1_triangle", "l2"};
  return names;
}

CacheTraceWriter::CacheTraceWriter(const std::string& path, const std::string& cache,
                                   const std::string& flag)
    : path_(path), cache_(cache), flag_(flag) {
  const auto& names = cache_trace_names();
  if (std::find(names.begin(), names.end(), cache) == names.end())
    throw InputError("--cache-trace", "unknown cache '" + cache + "' (l1_node | l1_triangle | l2)");
  file_ = open_for_writing(path, flag);
}

CacheTraceWriter::~CacheTraceWriter() { discard(file_, path_); }

void CacheTraceWriter::header(const CacheConfig& c, uint32_t instances) {
  std::fprintf(file_,
               "# rtsim cache trace 1\n# cache %s\n# instances %u\n# size_bytes %u\n# line_bytes %u\n"
               "# associativity %u\n# interleave %u\n"
               "# policy lru write-back write-allocate-without-fill\n",
               cache_.c_str(), instances, c.size_bytes, c.line_bytes, c.associativity, c.interleave);
}

void CacheTraceWriter::write(uint32_t instance, const LineAccess& a, CacheModel::Outcome outcome) {
  const char* what = outcome == CacheModel::Outcome::Hit      ? "hit"
                     : outcome == CacheModel::Outcome::Merged ? "merge"
                                                              : "miss";
  std::fprintf(file_, "%u %s 0x%" PRIx64 " %s\n", instance, a.write ? "W" : "R", a.line, what);
}

void CacheTraceWriter::footer(uint64_t writebacks) {
  std::fprintf(file_, "# writebacks %" PRIu64 "\n", writebacks);
}

void CacheTraceWriter::close() { close_checked(file_, path_, flag_); }

}  // namespace rtsim::sim
