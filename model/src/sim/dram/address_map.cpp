#include <rtsim/model/sim/dram/address_map.h>
#include <rtsim/model/sim/dram/protocol.h>
#include <rtsim/workloads/error.h>

#include <algorithm>
#include <sstream>

namespace rtsim::sim {

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
  offset_bits_ = dram_field_bits(access_bytes);
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

}  // namespace rtsim::sim
