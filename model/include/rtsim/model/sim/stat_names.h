#pragma once
// The names a user counts, declared once (gem5's statistics::Group is the model).
// The model writes its statistics under these; Table 1, the claim, the campaign
// report and docs/stats.md read them from here, and the plot scripts from the
// vocabulary the report hands them (vocabulary_json), so a figure shows the stat
// it names and a test can hold the one to the other.
//   byte kinds     access_kind_name (fetch.h): node, prim_ref, triangle, stack
//   ray types      ray_type_name (ray.h): primary, ao, shadow, reflection, refraction
//   cycle buckets  cycle_bucket_name (accounting.h), per unit kind
//   energy parts   kEnergyComponents (energy.h)
#include <rtsim/model/sim/accounting.h>

#include <nlohmann/json.hpp>

#include <vector>

namespace rtsim::sim::stat {

// DRAM bytes read, charged as the L2's fills are: <this>.<ray type>.<byte kind>, and
// <this>.total (= dram.bytes).
inline constexpr const char* kDramBytesByType = "dram.bytes_by_type";
inline constexpr const char* kDramBytes = "dram.bytes";
inline constexpr const char* kDramBytesPerRay = "dram.bytes_per_ray";
inline constexpr const char* kRays = "rays.total";
inline constexpr const char* kCycles = "time.cycles";
inline constexpr const char* kEnergyPerRay = "energy.pj_per_ray";  // = the sum of energy.<part>.pj_per_ray
// Per-ray-type counts: <this>.<ray type>.rays, .trv_ops, ...
inline constexpr const char* kPerType = "per_type";

}  // namespace rtsim::sim::stat

namespace rtsim::sim {

// Every kind of unit a machine can have: TRV, IST, shading, then the optional stages.
std::vector<const UnitTraits*> all_unit_kinds();

// Every name above, and the stats they head, as the reports and their scripts read them:
// {"byte_kinds": [...], "ray_types": [...], "cycle_buckets": [{name, meaning}],
//  "unit_kinds": [{name, buckets}], "energy_components": [...], "stats": {...}}.
nlohmann::json vocabulary_json();

}  // namespace rtsim::sim
