#include <rtsim/model/sim/stat_names.h>

#include <rtsim/model/core/fetch.h>
#include <rtsim/model/core/ray.h>
#include <rtsim/model/sim/accounting.h>
#include <rtsim/model/sim/energy.h>

namespace rtsim::sim {

nlohmann::json vocabulary_json() {
  using nlohmann::json;
  json kinds = json::array(), types = json::array(), buckets = json::array(), units = json::array();
  for (int k = 0; k < kAccessKindCount; ++k) kinds.push_back(access_kind_name(AccessKind(k)));
  for (RayType t : kAllRayTypes) types.push_back(ray_type_name(t));
  for (CycleBucket b : kAllCycleBuckets)
    buckets.push_back({{"name", cycle_bucket_name(b)}, {"meaning", cycle_bucket_meaning(b)}});
  for (UnitKind u : kAllUnitKinds) {
    json has = json::array();
    for (CycleBucket b : kAllCycleBuckets)
      if (unit_has_bucket(u, b)) has.push_back(cycle_bucket_name(b));
    units.push_back({{"name", unit_kind_name(u)}, {"buckets", has}});
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
