#include <rtsim/model/core/exact_referee.h>
#include <rtsim/model/core/validate.h>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rtsim {

namespace {
enum class Verdict : uint8_t { Agree, PrimTied, EndpointTie, HitMiss, Distance };
// What the referee said of a disagreement.
enum class Ruling : uint8_t { None, EmbreeWrong, CoreWrong, BothAdmissible };
const char* ruling_text(Ruling r) {
  switch (r) {
    case Ruling::EmbreeWrong: return "referee: Embree wrong";
    case Ruling::CoreWrong: return "referee: core wrong";
    case Ruling::BothAdmissible: return "referee: both admissible (exactly on an edge or endpoint)";
    default: return "no referee";
  }
}

// A hit that only one side sees, at a distance within the bound of the ray's
// tmin or tmax: the ray touches a surface exactly where its interval starts or
// ends (e.g. an AO ray leaving a corner in the plane of the adjacent wall).
bool at_endpoint(const Ray& r, float t, const ValidationRule& rule) {
  const float bound_min = rule.relative_bound * std::fabs(r.tmin) + rule.absolute_bound;
  if (std::fabs(t - r.tmin) <= bound_min) return true;
  if (!std::isfinite(r.tmax)) return false;
  return std::fabs(r.tmax - t) <= rule.relative_bound * r.tmax + rule.absolute_bound;
}
}

ValidationResult validate_against_embree(const EmbreeScene& embree, const std::vector<Ray>& rays,
                                         const std::vector<TraceResult>& results,
                                         const ValidationRule& rule, uint32_t threads,
                                         const Scene* referee_scene) {
  std::vector<Verdict> verdict(rays.size(), Verdict::Agree);
  std::vector<Ruling> ruling(rays.size(), Ruling::None);
  std::vector<EmbreeHit> reference(rays.size());
  auto body = [&] {
    tbb::parallel_for(size_t(0), rays.size(), [&](size_t i) {
      const Ray& r = rays[i];
      const HitRecord& mine = results[i].hit;
      if (traversal_mode_for(r.type) == TraversalMode::AnyHit) {
        const bool occluded = embree.occluded(r.origin, r.direction, r.tmin, r.tmax);
        reference[i].hit = occluded;
        if (occluded != mine.hit()) {
          // Where is the hit the other side missed? (Embree's closest one if it is Embree's.)
          if (occluded) reference[i] = embree.intersect(r.origin, r.direction, r.tmin, r.tmax);
          const float t = occluded ? reference[i].t : mine.t;
          verdict[i] = (!reference[i].hit && occluded) || !at_endpoint(r, t, rule)
                           ? Verdict::HitMiss : Verdict::EndpointTie;
        }
        return;
      }
      const EmbreeHit e = embree.intersect(r.origin, r.direction, r.tmin, r.tmax);
      reference[i] = e;
      if (e.hit != mine.hit()) {
        verdict[i] = at_endpoint(r, e.hit ? e.t : mine.t, rule) ? Verdict::EndpointTie : Verdict::HitMiss;
      } else if (e.hit) {
        const float bound = rule.relative_bound * std::max(e.t, mine.t) + rule.absolute_bound;
        if (!(std::fabs(e.t - mine.t) <= bound))
          verdict[i] = Verdict::Distance;
        else if (e.prim != mine.prim || e.instance != mine.instance)
          verdict[i] = Verdict::PrimTied;
      }
    });
    if (!referee_scene) return;
    // The disputed rays, each against every triangle of the scene, exactly.
    std::vector<size_t> disputed;
    for (size_t i = 0; i < rays.size(); ++i)
      if (verdict[i] == Verdict::HitMiss || verdict[i] == Verdict::Distance) disputed.push_back(i);
    const ExactReferee referee(*referee_scene, rule.relative_bound, rule.absolute_bound);
    tbb::parallel_for(size_t(0), disputed.size(), [&](size_t k) {
      const size_t i = disputed[k];
      const Ray& r = rays[i];
      const std::vector<RefereeCandidate> found = referee.candidates(r);
      const HitRecord& mine = results[i].hit;
      const bool core_ok = referee.admissible(r, found, {mine.hit(), mine.t, mine.prim, mine.instance});
      const bool embree_ok =
          referee.admissible(r, found, {reference[i].hit, reference[i].t, reference[i].prim, reference[i].instance});
      ruling[i] = !core_ok ? Ruling::CoreWrong : embree_ok ? Ruling::BothAdmissible : Ruling::EmbreeWrong;
    });
  };
  if (threads) {
    tbb::task_arena arena{int(threads)};
    arena.execute(body);
  } else {
    body();
  }
  ValidationResult out;
  out.rays = rays.size();
  out.refereed = referee_scene != nullptr;
  for (size_t i = 0; i < rays.size(); ++i) {
    const Verdict v = verdict[i];
    if (v == Verdict::Agree) continue;
    if (v == Verdict::PrimTied) {
      ++out.prim_tied;
      continue;
    }
    if (v == Verdict::EndpointTie) {
      ++out.endpoint_ties;
      continue;
    }
    ++out.disagreements;
    ++out.disagreements_by_type[ray_type_index(rays[i].type)];
    (v == Verdict::HitMiss ? out.hit_miss : out.distance) += 1;
    if (ruling[i] == Ruling::EmbreeWrong) ++out.embree_wrong;
    if (ruling[i] == Ruling::CoreWrong) ++out.core_wrong;
    if (ruling[i] == Ruling::BothAdmissible) ++out.both_admissible;
    // The examples show what fails first: core-wrong rays, then the others.
    const bool show = out.examples.size() < 10 && (!out.refereed || ruling[i] == Ruling::CoreWrong ||
                                                   out.examples.size() < 5);
    if (show) {
      const Ray& r = rays[i];
      char line[512];
      std::snprintf(line, sizeof line,
                    "ray %zu (%s, pixel %u): core %s t=%.9g prim=%d, embree %s t=%.9g prim=%d; "
                    "o=(%.9g %.9g %.9g) d=(%.9g %.9g %.9g) tmin=%g tmax=%g; %s",
                    i, ray_type_name(r.type), r.pixel, results[i].hit.hit() ? "hit" : "miss",
                    results[i].hit.t, int(results[i].hit.prim), reference[i].hit ? "hit" : "miss",
                    reference[i].t, int(reference[i].prim), r.origin.x, r.origin.y, r.origin.z,
                    r.direction.x, r.direction.y, r.direction.z, r.tmin, r.tmax, ruling_text(ruling[i]));
      out.examples.push_back(line);
    }
  }
  return out;
}

}  // namespace rtsim
