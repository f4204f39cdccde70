#pragma once
// Where a physical address lives in the DRAM: channel, rank, bank group, bank, row and
// column, by dram.address_mapping (a mixed-radix number whose digits it names).
#include <rtsim/model/sim/config.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rtsim::sim {

struct DramAddress {
  uint32_t channel = 0, rank = 0;
  uint32_t bank_group = 0;
  uint32_t bank = 0;  // within the rank, 0 .. banks-1; bank_group = bank / banks_per_group
  uint32_t column = 0;
  uint64_t row = 0;
};

// dram.address_mapping's field names, most significant first ("row:rank:...:channel").
std::vector<std::string> dram_mapping_fields(const std::string& mapping);
// Bits that hold `values` distinct values (0 for 1): a field's width in a bit-field mapping.
uint32_t dram_field_bits(uint64_t values);

class DramAddressMap {
 public:
  DramAddressMap(const DramConfig& config, uint32_t access_bytes);
  DramAddress decode(uint64_t address) const;

 private:
  enum Which : uint8_t { Row, Rank, Bank, Column, Channel, BankGroup };
  struct Field {
    Which which;
    uint64_t radix;  // values the field takes (0: all that is left)
  };
  std::vector<Field> fields_;
  uint32_t offset_bits_;
  uint32_t banks_per_group_;
  bool group_field_ = false;  // without one, the group is the bank number's top bits
};

}  // namespace rtsim::sim
