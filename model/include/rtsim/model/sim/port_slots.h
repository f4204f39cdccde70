#pragma once
// The cycles (slots) a port is taken, for reservations made out of time order.
// The loosely-timed level reserves a request's port at the time the request gets
// there, which can lie ahead of a later call's (a response after a DRAM access is
// reserved before a hit's that returns sooner). A single "next free" time would
// make the sooner one wait behind the later one; the slots let it take a free
// cycle at its own time. Used by the caches' ports and the crossbar's.
// A ring of bits remembers every slot within `horizon_ps` of the newest taken, and
// more; a slot older than the ring counts as free (no request comes that late).
#include <algorithm>
#include <cstdint>
#include <vector>

namespace rtsim::sim {

class PortSlots {
 public:
  PortSlots(uint64_t interval_ps, uint64_t horizon_ps);
  uint64_t interval_ps() const { return interval_ps_; }
  // The first slot from `slot` on that is free. Inline when nothing is taken from
  // `slot` on, as for most requests: time moves forward.
  uint64_t first_free(uint64_t slot) const {
    if (!any_taken_ || slot > newest_slot_ || forgotten(slot)) return slot;
    return first_free_among_taken(slot);
  }
  // Older than the ring remembers: free, and not to be taken (its bit is a newer slot's).
  bool forgotten(uint64_t slot) const { return any_taken_ && slot + ring_slots() <= newest_slot_; }
  void take(uint64_t slot) {
    if (any_taken_ && slot <= newest_slot_ + 1) {
      // Within the ring, or the slot right after the newest (nothing to clear but
      // its own bit, which is set anyway).
      word(slot) |= uint64_t(1) << (slot % 64);
      newest_slot_ = std::max(newest_slot_, slot);
      return;
    }
    take_ahead(slot);
  }

 private:
  // The ring holds a power of two of slots: a mask, not a division, finds a slot's word.
  uint64_t ring_slots() const { return ring_mask_ + 1; }
  uint64_t first_free_among_taken(uint64_t slot) const;
  void take_ahead(uint64_t slot);          // a slot past the newest but one
  void clear(uint64_t from, uint64_t to);  // slots [from, to], fewer than the ring holds
  uint64_t& word(uint64_t slot) { return bits_[(slot & ring_mask_) / 64]; }
  uint64_t word(uint64_t slot) const { return bits_[(slot & ring_mask_) / 64]; }
  uint64_t interval_ps_;
  uint64_t ring_mask_ = 63, newest_slot_ = 0;
  bool any_taken_ = false;
  std::vector<uint64_t> bits_;
};

}  // namespace rtsim::sim
