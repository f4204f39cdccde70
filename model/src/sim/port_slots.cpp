#include <rtsim/model/sim/port_slots.h>

#include <algorithm>

namespace rtsim::sim {

PortSlots::PortSlots(uint64_t interval_ps, uint64_t horizon_ps)
    : interval_ps_(std::max<uint64_t>(1, interval_ps)) {
  uint64_t slots = 64;
  while (slots < 2 * (horizon_ps / interval_ps_ + 1)) slots *= 2;
  ring_mask_ = slots - 1;
  bits_.assign(slots / 64, 0);
}

uint64_t PortSlots::first_free_among_taken(uint64_t slot) const {
  // A 64-slot word at a time: a busy port has long runs of taken slots. Every slot
  // past the newest is free.
  while (slot <= newest_slot_) {
    const uint32_t offset = uint32_t(slot % 64);
    const uint64_t free_bits = ~(word(slot) >> offset);  // bit i: slot + i is free
    const uint32_t run = free_bits ? uint32_t(__builtin_ctzll(free_bits)) : 64;
    // Bits past the newest may be left from an older lap of the ring: those are free.
    if (run < 64 - offset) return std::min(slot + run, newest_slot_ + 1);
    slot += 64 - offset;
  }
  return newest_slot_ + 1;
}

void PortSlots::clear(uint64_t from, uint64_t to) {
  // The part of each 64-slot word within [from, to] at once.
  while (from <= to) {
    const uint32_t offset = uint32_t(from % 64);
    const uint64_t count = std::min<uint64_t>(64 - offset, to - from + 1);
    const uint64_t bits = count == 64 ? ~uint64_t(0) : ((uint64_t(1) << count) - 1) << offset;
    word(from) &= ~bits;
    from += count;
  }
}

void PortSlots::take_ahead(uint64_t slot) {
  // Slots past the newest come into the ring: clear what they overwrite.
  const uint64_t from = any_taken_ ? newest_slot_ + 1 : slot;
  if (slot - from >= ring_slots()) std::fill(bits_.begin(), bits_.end(), 0);
  else clear(from, slot);
  newest_slot_ = slot;
  any_taken_ = true;
  word(slot) |= uint64_t(1) << (slot % 64);
}

}  // namespace rtsim::sim
