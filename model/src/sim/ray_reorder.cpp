#include <rtsim/model/core/traversal.h>
#include <rtsim/model/sim/ray_reorder.h>
#include <rtsim/model/sim/stats.h>

#include <algorithm>
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

void report_reorder(StatsRegistry& s, const HardwareConfig& c, const ReorderFigures& f, bool timed) {
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
  if (parse_reorder_key(c.reorder_key) == ReorderKey::FirstNode)
    s.set("reorder.key_box_tests", f.key_box_tests, "tests", "root box tests computing the first_node key");
}

}  // namespace rtsim::sim
