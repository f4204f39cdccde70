#pragma once
// Checks the functional core against Embree, ray by ray.
#include <rtsim/model/core/functional_tracer.h>
#include <rtsim/workloads/embree_scene.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace rtsim {

// Agreement rule. Closest-hit rays: both hit or both miss; when both hit, the
// distances agree within `relative_bound` x max(t_core, t_embree) (plus
// `absolute_bound` for hits at t ~ 0), and the primitive is the same unless the
// two distances tie within that bound (two triangles meeting where the ray
// lands). Any-hit rays: both occluded or both open. A hit seen by one side only
// is a tie, not a disagreement, when it lies within the bound of the ray's tmin
// or tmax (the ray touches a surface exactly where its interval starts or ends).
struct ValidationRule {
  float relative_bound = 1e-4f;
  float absolute_bound = 0.0f;  // world units; callers pass ~1e-6 x the scene diagonal
};

// With a referee (the scene given), every disagreement is decided exactly
// (exact_referee.h): "Embree wrong" when only the core's answer is admissible,
// "core wrong" when the core's is not (whatever Embree said), "both admissible"
// when the ray passes exactly through an edge or an endpoint where either
// answer is right. Only "core wrong" fails validation.
struct ValidationResult {
  uint64_t rays = 0;
  uint64_t disagreements = 0;  // before the referee
  bool refereed = false;
  uint64_t embree_wrong = 0, core_wrong = 0, both_admissible = 0;
  // What fails validation: core_wrong when refereed, else every disagreement.
  uint64_t failures() const { return refereed ? core_wrong : disagreements; }
  uint64_t hit_miss = 0, distance = 0;
  uint64_t prim_tied = 0;      // allowed: different prim, distances tie
  uint64_t endpoint_ties = 0;  // allowed: one-sided hit at tmin or tmax
  std::array<uint64_t, kRayTypeCount> disagreements_by_type{};
  std::vector<std::string> examples;  // the first few disagreements, one line each
};

// `referee_scene`: the scene Embree was built from; when given, disagreements go
// to the exact referee.
ValidationResult validate_against_embree(const EmbreeScene& embree, const std::vector<Ray>& rays,
                                         const std::vector<TraceResult>& results,
                                         const ValidationRule& rule = {}, uint32_t threads = 0,
                                         const Scene* referee_scene = nullptr);

}  // namespace rtsim
