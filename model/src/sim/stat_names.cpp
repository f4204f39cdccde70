#include <rtsim/model/sim/stat_names.h>

#include <rtsim/model/core/fetch.h>
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/energy.h>
#include <rtsim/model/sim/ray_dispatch.h>

namespace rtsim::sim {

std::vector<const UnitTraits*> all_unit_kinds() {
  std::vector<const UnitTraits*> out;
  for (UnitKind u : kAllUnitKinds) out.push_back(&unit_traits(u));
  for (const StageDescription& stage : RayDispatcher::stage_kinds()) out.push_back(stage.traits);
  return out;
}

nlohmann::json vocabulary_json() {
  using nlohmann::json;
  json kinds = json::array(), types = json::array(), buckets = json::array(), units = json::array();
  for (int k = 0; k < kAccessKindCount; ++k) kinds.push_back(access_kind_name(AccessKind(k)));
  for (RayType t : kAllRayTypes) types.push_back(ray_type_name(t));
  for (CycleBucket b : kAllCycleBuckets)
    buckets.push_back({{"name", cycle_bucket_name(b)}, {"meaning", cycle_bucket_meaning(b)}});
  for (const UnitTraits* u : all_unit_kinds()) {
    json has = json::array();
    for (CycleBucket b : kAllCycleBuckets)
      if (u->has(b)) has.push_back(cycle_bucket_name(b));
    units.push_back({{"name", u->name}, {"buckets", has}});
  }
  json energy = json::array();
  for (const char* part : kEnergyComponents) energy.push_back(part);
  return {{"byte_kinds", kinds},
          {"ray_types", types},
          {"cycle_buckets", buckets},
          {"unit_kinds", units},
          {"energy_components", energy},
          {"stats",
           {{"dram_bytes_by_type", stat::kDramBytesByType},
            {"dram_bytes", stat::kDramBytes},
            {"dram_bytes_per_ray", stat::kDramBytesPerRay},
            {"rays", stat::kRays},
            {"cycles", stat::kCycles},
            {"energy_per_ray", stat::kEnergyPerRay},
            {"per_type", stat::kPerType}}}};
}

}  // namespace rtsim::sim
