#pragma once
// The referee of validation: where the functional core and Embree disagree on a
// ray, the exact answer decides which of them is wrong. Ray and triangles are
// taken as the float values both sides were given; the side of every triangle
// edge the ray's line passes is decided by the exact sign of the edge function
// det[p - o, q - o, d] (floating-point expansions, see exact_referee.cpp), so
// "inside", "outside" and "exactly on an edge" are facts, not roundings. The
// distance of a hit is computed in long double.
#include <rtsim/model/core/ray.h>
#include <rtsim/workloads/scene.h>

#include <cstdint>
#include <vector>

namespace rtsim {

// Where the exact ray meets one triangle.
struct RefereeCandidate {
  uint32_t prim = 0;
  uint32_t instance = kNoInstance;  // instanced scenes: whose placement of prim
  long double t = 0;
  bool on_boundary = false;  // exactly on an edge or a vertex: hit or miss are both admissible
  bool at_endpoint = false;  // t within the distance bound of tmin or tmax: likewise
  // Alpha-tested triangle whose alpha test is decided by where exactly the ray
  // lands (a texel edge between an opaque and a clear texel lies within rounding of
  // the hit): hit or miss are both admissible. Hits on clear texels are no candidates.
  bool alpha_ambiguous = false;
  bool required() const { return !on_boundary && !at_endpoint && !alpha_ambiguous; }
};

// One answer to a ray: hit or not, and for a closest hit where and what.
struct RayAnswer {
  bool hit = false;
  float t = 0.0f;
  uint32_t prim = kNoPrim;
  uint32_t instance = kNoInstance;
};

class ExactReferee {
 public:
  // `relative_bound` and `absolute_bound`: how far a reported distance may be from
  // the exact one (the validation rule's bounds).
  ExactReferee(const Scene& scene, float relative_bound, float absolute_bound);

  // Every triangle the ray meets in [tmin, tmax] (closed triangles, endpoints
  // with the bound), by brute force over the scene: for the few rays in dispute.
  // Instanced scenes: every instance's triangles, in its object space.
  std::vector<RefereeCandidate> candidates(const Ray& ray) const;

  // Whether an answer is admissible for the ray. Closest hit: a miss when no
  // required candidate exists; a hit when it names a candidate at its distance
  // (within the bound) with no required candidate clearly nearer. Any hit: hit
  // when any candidate exists, no hit when none is required.
  bool admissible(const Ray& ray, const std::vector<RefereeCandidate>& candidates,
                  const RayAnswer& answer) const;

 private:
  void add_candidates(const Ray& ray, uint32_t first, uint32_t end, uint32_t instance,
                      std::vector<RefereeCandidate>& out) const;
  const Scene& scene_;
  float relative_bound_, absolute_bound_;
  std::vector<glm::mat4> world_to_object_;  // instanced scenes, per instance
};

// The exact sign (-1, 0, +1) of det[p - o, q - o, d] = ((p - o) x (q - o)) . d for
// float inputs; exposed for tests.
int exact_edge_sign(const vec3& origin, const vec3& direction, const vec3& p, const vec3& q);

}  // namespace rtsim
