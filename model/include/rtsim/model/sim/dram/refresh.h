#pragma once
// The refresh manager: all-bank refresh of every rank once per tREFI, the ranks of a
// channel staggered over the interval so that a channel never loses all of them at
// once. A rank whose refresh is due has its open banks precharged, then takes REF,
// then no activate for tRFC (the device's rule). From its due time a rank takes no new
// activate or column command (the scheduler asks due()).
#include <rtsim/model/sim/dram/device.h>

#include <cstdint>
#include <vector>

namespace rtsim::sim {

class DramRefreshManager {
 public:
  DramRefreshManager(const DramTimings& timings, uint32_t channels, uint32_t ranks);
  // When the rank's next refresh is due (UINT64_MAX: never, tREFI = 0).
  uint64_t due(uint32_t channel, uint32_t rank) const { return due_[size_t(channel) * ranks_ + rank]; }
  // The refresh work due by `horizon` (precharges of its open banks, else the REF).
  void offer(DramDevice& device, DramDevice::Channel& ch, uint64_t horizon, DramCandidate& best) const;
  // The rank's REF went: the next is due one tREFI after this one was (so that the
  // average rate is exact however late each went).
  void refreshed(uint32_t channel, uint32_t rank) { due_[size_t(channel) * ranks_ + rank] += refi_; }

 private:
  uint32_t ranks_;
  uint64_t refi_;
  std::vector<uint64_t> due_;  // channel x rank
};

}  // namespace rtsim::sim
