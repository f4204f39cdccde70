#include <rtsim/model/sim/dram/refresh.h>

namespace rtsim::sim {

DramRefreshManager::DramRefreshManager(const DramTimings& timings, uint32_t channels, uint32_t ranks)
    : ranks_(ranks), refi_(timings.refi), due_(size_t(channels) * ranks, UINT64_MAX) {
  if (refi_ == 0) return;
  // Ranks refresh staggered over the interval, so a channel never loses all at once.
  for (uint32_t c = 0; c < channels; ++c)
    for (uint32_t r = 0; r < ranks; ++r) due_[size_t(c) * ranks + r] = timings.edge(refi_ * (r + 1) / ranks);
}

// Its commands come no earlier than the due time, so a later refresh cannot compete.
void DramRefreshManager::offer(DramDevice& device, DramDevice::Channel& ch, uint64_t horizon,
                               DramCandidate& best) const {
  for (uint32_t r = 0; r < ranks_; ++r) {
    const uint64_t t = due(ch.index, r);
    if (t == UINT64_MAX || t > horizon || t > best.time_ps) continue;
    bool any_open = false;
    for (uint32_t b = 0; b < device.banks(); ++b) {
      if (device.bank_state(ch, r, b).open_row < 0) continue;
      any_open = true;
      DramCandidate c;
      c.time_ps = device.earliest_precharge(ch, r, b, t), c.priority = 0, c.age = 0;
      c.action = DramCandidate::Action::Precharge, c.rank = r, c.bank = b;
      keep_best(best, c);
    }
    if (!any_open) {
      DramCandidate c;
      c.time_ps = device.earliest_refresh(ch, r, t), c.priority = 0, c.age = 0;
      c.action = DramCandidate::Action::Refresh, c.rank = r;
      keep_best(best, c);
    }
  }
}

}  // namespace rtsim::sim
