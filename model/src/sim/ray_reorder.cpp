#include <rtsim/model/core/traversal.h>
#include <rtsim/model/sim/ray_reorder.h>
#include <rtsim/model/sim/stats.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rtsim::sim {

ReorderKey parse_reorder_key(const std::string& text) {
  if (text == "none") return ReorderKey::None;
  if (text == "origin") return ReorderKey::Origin;
  if (text == "octant_origin") return ReorderKey::OctantOrigin;
  if (text == "first_node") return ReorderKey::FirstNode;
  throw std::invalid_argument("reorder.key: '" + text + "' is not none, origin, octant_origin or first_node");
}

RayReorderKeys::RayReorderKeys(ReorderKey key, const TraversalContext& context)
    : key_(key), bounds_(context.bvh().empty() ? Aabb{} : context.bvh().root().bounds) {
  if (key == ReorderKey::FirstNode) probe_ = std::make_unique<RayTraversal>(context);
}

RayReorderKeys::~RayReorderKeys() = default;

uint64_t RayReorderKeys::operator()(const Ray& ray) const {
  // 10 bits per axis: a batch of at most 4096 rays never needs finer cells.
  const auto origin = [&] { return morton_code(ray.origin, bounds_, 1024); };
  switch (key_) {
    case ReorderKey::None: return 0;
    case ReorderKey::Origin: return origin();
    case ReorderKey::OctantOrigin: {
      const uint64_t octant = uint64_t(ray.direction.x < 0) | uint64_t(ray.direction.y < 0) << 1 |
                              uint64_t(ray.direction.z < 0) << 2;
      return octant << 30 | origin();
    }
    case ReorderKey::FirstNode: {
      // The root's box tests as TRV does them: the node it then enters, leaves and
      // nodes alike by node index; a ray that misses the root goes last.
      RayTraversal& t = *probe_;
      t.reset(ray);
      if (t.done()) return UINT64_MAX;
      t.process();
      box_tests_ += t.last_step_box_tests();
      return t.done() ? UINT64_MAX : t.node();
    }
  }
  return 0;
}

void RayReorderBuffer::sort_batch(uint64_t now_ps, const std::vector<Ray>& rays) {
  std::stable_sort(batch_.begin(), batch_.end(), [](const Entry& a, const Entry& b) { return a.key < b.key; });
  formed_ps_ = now_ps;
  ready_ps_ = now_ps == UINT64_MAX ? now_ps : now_ps + latency_ps_;
  if (now_ps != UINT64_MAX) {  // busy sorting, then holding the sorted rays
    accounting.change(now_ps, UnitAccounting::Resident, +1);
    accounting.reserve(now_ps, now_ps, ready_ps_);
    accounting.change(now_ps, ready_ps_, UnitAccounting::Blocked, +1);
  }
  ++counters_.batches;
  counters_.full_batches += batch_.size() == batch_rays_;
  counters_.rays += batch_.size();
  for (const Entry& e : batch_) ++counters_.rays_by_type[size_t(rays[e.ray].type)];
}

uint32_t reorder_sort_cycles(const HardwareConfig& c, uint32_t rays) {
  uint32_t k = 0;
  while ((1ull << k) < rays) ++k;
  return k * (k + 1) / 2 * c.reorder_stage_cycles;
}

ReorderSettings ReorderSettings::from(const HardwareConfig& c) {
  ReorderSettings r;
  r.batch_rays = c.reorder_batch_rays;
  r.key = parse_reorder_key(c.reorder_key);
  r.latency_ps = uint64_t(std::llround(reorder_sort_cycles(c, c.reorder_batch_rays) * c.clock_period_ps()));
  r.entry_bytes = c.reorder_entry_bytes;
  return r;
}

RayReorderUnit::RayReorderUnit(const ReorderSettings& settings, uint32_t cores, const TraversalContext& context)
    : settings_(settings), keys_(settings.key, context),
      buffers_(cores, RayReorderBuffer(settings.batch_rays, settings.latency_ps)) {}

const StageDescription& RayReorderUnit::description() {
  // The sort is its busy time, then its rays are blocked at once until TRV takes them.
  static const UnitTraits traits{"reorder",
                                 bucket_set({CycleBucket::Busy, CycleBucket::Blocked, CycleBucket::Idle})};
  static const StageDescription d{&traits, "reorder.batch_rays = 64\nreorder.key = \"first_node\"\n"};
  return d;
}

const UnitTraits& RayReorderUnit::traits() const { return *description().traits; }

bool RayReorderUnit::holding_any() const {
  for (const RayReorderBuffer& b : buffers_)
    if (b.holding()) return true;
  return false;
}

void RayReorderUnit::restart(uint64_t t) {
  for (RayReorderBuffer& b : buffers_) b.restart(t);
  keys_.restart();
}

ReorderFigures RayReorderUnit::figures() const {
  ReorderFigures f;
  for (const RayReorderBuffer& b : buffers_) {
    const ReorderCounters& c = b.counters();
    f.total.batches += c.batches, f.total.full_batches += c.full_batches, f.total.rays += c.rays;
    f.total.wait_ps += c.wait_ps;
    for (size_t t = 0; t < kRayTypeCount; ++t) f.total.rays_by_type[t] += c.rays_by_type[t];
  }
  f.key_box_tests = keys_.box_tests();
  return f;
}

StageWork RayReorderUnit::work(uint32_t core) const {
  return {buffers_[core].counters().rays, "rays", "rays the unit sorted and released"};
}

void RayReorderUnit::report(StatsRegistry& s, const HardwareConfig& c, bool timed) const {
  const ReorderFigures f = figures();
  const ReorderCounters& t = f.total;
  s.set("reorder.batches", t.batches, "batches", "sorted batches the ray-reordering units released");
  s.set("reorder.full_batches", t.full_batches, "batches",
        "batches of reorder.batch_rays rays (the rest formed when fewer rays were ready)");
  s.set("reorder.rays", t.rays, "rays", "rays through the ray-reordering units");
  s.set_real("reorder.rays_per_batch", t.batches ? double(t.rays) / double(t.batches) : 0, "rays/batch",
             "reorder.rays / reorder.batches");
  if (timed)
    s.set_real("reorder.wait_cycles_per_ray", t.rays ? double(t.wait_ps) / c.clock_period_ps() / double(t.rays) : 0,
               "cycles/ray", "mean cycles from a ray's batch forming to the ray leaving for TRV");
  if (settings_.key == ReorderKey::FirstNode)
    s.set("reorder.key_box_tests", f.key_box_tests, "tests", "root box tests computing the first_node key");
}

StageEnergy RayReorderUnit::energy(const HardwareConfig&, const EnergyPrices& prices) const {
  // Each ray is written into and read out of a buffer of batch_rays entries, priced
  // as a cache of that size; a first-node key adds its root box tests.
  const ReorderFigures f = figures();
  const uint64_t buffer_bytes = uint64_t(settings_.batch_rays) * settings_.entry_bytes;
  StageEnergy e;
  e.pj = double(f.total.rays) * 2 * cache_access_pj(buffer_bytes) * prices.sram +
         double(f.key_box_tests) * prices.energy.box_test_pj * prices.logic;
  for (size_t t = 0; t < kRayTypeCount; ++t) e.caused[t] = double(f.total.rays_by_type[t]);
  e.what = "the ray-reordering buffers (a write and a read per ray) and their key tests";
  e.what_per_ray = "the ray-reordering buffers";
  return e;
}

}  // namespace rtsim::sim
