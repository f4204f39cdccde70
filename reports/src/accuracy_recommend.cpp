// The recommendations of `rtsim accuracy`, derived from the measured numbers:
// every rule picks the cheapest setting whose error stays inside a stated tolerance.
#include <rtsim/reports/accuracy.h>
#include <rtsim/reports/text_table.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace rtsim {

namespace {

std::string secs(double s) { return format_significant(s, 3) + " s"; }
std::string integer(double v) { return std::to_string(static_cast<long long>(std::llround(v))); }
std::string alpha(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::vector<const KnobPoint*> family(const AccuracyReport& r, const std::string& name) {
  std::vector<const KnobPoint*> out;
  for (const KnobPoint& k : r.knobs)
    if (k.family == name) out.push_back(&k);
  return out;
}

const KnobPoint* reference_of(const std::vector<const KnobPoint*>& points) {
  for (const KnobPoint* p : points)
    if (p->reference) return p;
  return nullptr;
}

void fidelity_recommendations(const AccuracyReport& r, std::vector<Recommendation>& out) {
  if (r.fidelity.empty()) return;
  uint32_t largest = 0;
  for (const FidelityPoint& p : r.fidelity) largest = std::max(largest, p.resolution);
  // Speeds are the report's own scene's; errors are the worst over every scene.
  std::map<std::string, const FidelityPoint*> at_largest;
  std::map<std::string, double> worst_cycles, worst_dram;
  std::map<std::string, std::map<std::string, double>> worst_by_scene;  // level -> scene -> worst error
  std::vector<std::string> scenes;
  bool counts_match = true;
  for (const FidelityPoint& p : r.fidelity) {
    counts_match &= p.counts_match_cycle;
    worst_cycles[p.level] = std::max(worst_cycles[p.level], std::fabs(p.cycle_error));
    worst_dram[p.level] = std::max(worst_dram[p.level], std::fabs(p.dram_error));
    double& w = worst_by_scene[p.level][p.scene];
    w = std::max({w, std::fabs(p.cycle_error), std::fabs(p.dram_error)});
    if (std::find(scenes.begin(), scenes.end(), p.scene) == scenes.end()) scenes.push_back(p.scene);
    if (p.resolution == largest && p.scene == r.scene_name) at_largest[p.level] = &p;
  }
  const FidelityPoint* functional = at_largest["functional"];
  const FidelityPoint* cycle = at_largest["cycle"];
  if (!functional || !cycle) return;
  const double speedup = functional->rays_per_cpu_second / std::max(cycle->rays_per_cpu_second, 1e-9);

  Recommendation counts;
  counts.topic = "ops/ray, node fetches (Table 1 counts)";
  if (counts_match) {
    counts.setting = "fidelity functional";
    counts.why = "TRV, IST and ray counts were identical at all three levels in every run (one functional "
                 "core), and functional simulated " + format_significant(functional->rays_per_cpu_second, 3) +
                 " rays per CPU second against " + format_significant(cycle->rays_per_cpu_second, 3) +
                 " for cycle at " + std::to_string(largest) + "x" + std::to_string(largest) + " (" +
                 format_significant(speedup, 3) + "x faster).";
  } else {
    counts.setting = "fidelity cycle";
    counts.why = "the counts differed between levels in at least one run (a model bug): only the cycle "
                 "level can be trusted until that is fixed.";
  }
  out.push_back(counts);

  // Cycles and DRAM bytes: the fastest level whose worst error over all resolutions is
  // inside the tolerance; cycle itself is the reference and always qualifies.
  std::string best = "cycle";
  for (const char* level : {"lt", "functional"}) {
    const FidelityPoint* p = at_largest[level];
    if (!p) continue;
    if (worst_cycles[level] <= r.options.fidelity_tolerance && worst_dram[level] <= r.options.fidelity_tolerance &&
        p->rays_per_cpu_second > at_largest[best]->rays_per_cpu_second)
      best = level;
  }
  Recommendation timing;
  timing.topic = "cycles and DRAM bytes";
  timing.setting = "fidelity " + best;
  std::string errors;
  for (const char* level : {"functional", "lt"})
    errors += std::string(errors.empty() ? "" : "; ") + level + ": worst cycle error " + format_percent(worst_cycles[level]) +
              ", worst DRAM error " + format_percent(worst_dram[level]) + ", " +
              format_significant(at_largest[level] ? at_largest[level]->rays_per_cpu_second : 0, 3) + " rays per CPU second";
  // Where each faster level leaves the tolerance, scene by scene.
  std::string fails;
  for (const char* level : {"functional", "lt"})
    for (const auto& [scene, worst] : worst_by_scene[level])
      if (worst > r.options.fidelity_tolerance)
        fails += std::string(fails.empty() ? " Outside it: " : "; ") + level + " on " + scene + " (worst error " +
                 format_percent(worst) + ")";
  if (!fails.empty()) fails += ".";
  std::string over = std::to_string(scenes.size()) + (scenes.size() == 1 ? " scene (" : " scenes (");
  for (size_t i = 0; i < scenes.size(); ++i) over += (i ? ", " : "") + scenes[i];
  over += scenes.size() == 1 ? "; a compute-bound scene alone can hide a level's error on memory-bound ones)"
                             : ")";
  timing.why = "tolerance " + format_percent(r.options.fidelity_tolerance, 2) + " of the cycle level over " + over +
               ", speeds on " + r.scene_name + " (cycle " + format_significant(cycle->rays_per_cpu_second, 3) +
               " rays per CPU second at " + std::to_string(largest) + "x" + std::to_string(largest) + "): " + errors +
               "." + fails + " " +
               (best == "cycle" ? "No faster level stays inside the tolerance."
                                : "The fastest level inside the tolerance wins; use cycle for final numbers "
                                  "that must match the detailed model exactly.");
  out.push_back(timing);
}

void knob_recommendations(const AccuracyReport& r, std::vector<Recommendation>& out) {
  const double tol = r.options.tolerance;
  // Builder knobs trade build time for tree quality, so the test is one-sided: a
  // cheaper setting qualifies unless its tree costs more than `tol` extra ops/ray
  // (a cheaper tree that happens to be better is no reason to pay for the exact one).
  // AO rays per primitive: the smallest K from which on no larger K is worse than that.
  const auto ks = family(r, "ao_rays");
  if (const KnobPoint* ref = reference_of(ks)) {
    const KnobPoint* chosen = ref;
    for (size_t i = ks.size(); i-- > 0;) {
      if (!(ks[i]->ops_error <= tol)) break;
      chosen = ks[i];
    }
    // How fast the occlusion values converge, fitted over the measured K (least squares in log-log).
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int n = 0;
    for (const KnobPoint* k : ks)
      if (!k->reference && k->occlusion_rmse > 0) {
        const double x = std::log(k->value), y = std::log(k->occlusion_rmse);
        sx += x, sy += y, sxx += x * x, sxy += x * y, ++n;
      }
    const double slope = n >= 2 && n * sxx - sx * sx > 0 ? (n * sxy - sx * sy) / (n * sxx - sx * sx) : 0.0;
    Recommendation rec;
    rec.topic = "AO-BVH rays per primitive (K)";
    rec.setting = "--ao-rays " + integer(chosen->value);
    rec.why = "from K=" + integer(chosen->value) + " on, no tree costs more than " + format_percent(tol, 2) +
              " ops/ray above K=" + integer(ref->value) + " (" + format_significant(ref->ops_per_ray) + " ops/ray; K=" +
              integer(chosen->value) + ": " + format_significant(chosen->ops_per_ray) + ", " + format_percent(chosen->ops_error) +
              ", occlusion RMSE " + format_significant(chosen->occlusion_rmse, 3) + ") while estimating + building takes " +
              secs(chosen->cpu_seconds) + " of CPU instead of " + secs(ref->cpu_seconds) + ".";
    if (n >= 2)
      rec.why += " The occlusion RMSE falls as K^" + format_significant(slope, 2) +
                 " (Monte Carlo: K^-0.5), the tree's ops/ray much sooner: the SAH only needs the weights' "
                 "ranking to be roughly right.";
    out.push_back(rec);
  }
  // Shared AO estimates: the largest G up to which no tree costs more than `tol`
  // extra ops/ray against the K-rays-per-triangle reference.
  auto shares = family(r, "ao_share");
  std::sort(shares.begin(), shares.end(), [](const KnobPoint* a, const KnobPoint* b) { return a->value < b->value; });
  const KnobPoint* ref_k = reference_of(ks);
  if (!shares.empty() && ref_k) {
    const KnobPoint* chosen = nullptr;
    for (const KnobPoint* g : shares) {
      if (!(g->ops_error <= tol)) break;
      chosen = g;
    }
    Recommendation rec;
    rec.topic = "AO-BVH estimates shared by nearby triangles (G)";
    if (chosen) {
      rec.setting = "--ao-share " + integer(chosen->value);
      rec.why = "up to G=" + integer(chosen->value) + " no tree costs more than " + format_percent(tol, 2) + " ops/ray above K=" +
                integer(ref_k->value) + " per triangle (G=" + integer(chosen->value) + ": " +
                format_significant(chosen->ops_per_ray) + ", " + format_percent(chosen->ops_error) + ", occlusion RMSE " +
                format_significant(chosen->occlusion_rmse, 3) + ") while estimating + building takes " + secs(chosen->cpu_seconds) +
                " of CPU (G=" + integer(shares.front()->value) + ": " + secs(shares.front()->cpu_seconds) +
                "). One seed: the tree's seed spread (docs/build-speed.md) is of the same size on some scenes.";
    } else {
      rec.setting = "--ao-share 1";
      rec.why = "already G=" + integer(shares.front()->value) + " costs " + format_percent(shares.front()->ops_error) +
                " ops/ray against K=" + integer(ref_k->value) + " per triangle.";
    }
    out.push_back(rec);
  }
  const auto bins = family(r, "sah_bins");
  if (const KnobPoint* ref = reference_of(bins)) {
    const KnobPoint* binned = nullptr;
    for (const KnobPoint* p : bins)
      if (!p->reference) binned = p;
    if (binned) {
      Recommendation rec;
      rec.topic = "SAH split search";
      const bool good = binned->ops_error <= tol;
      rec.setting = good ? "--bins " + integer(binned->value) : "--bins 0 (full sweep)";
      rec.why = binned->label + ": " + format_significant(binned->ops_per_ray) + " ops/ray (" + format_percent(binned->ops_error) +
                " against the full sweep's " + format_significant(ref->ops_per_ray) + "), SAH cost " +
                format_significant(binned->sah_cost) + " vs " + format_significant(ref->sah_cost) + ", build " +
                secs(binned->cpu_seconds) + " vs " + secs(ref->cpu_seconds) + " of CPU; " +
                (good ? (binned->ops_error <= 0 ? std::string("binning is no worse here, and faster.")
                                                : "at most " + format_percent(tol, 2) + " worse, so binning's speed is worth it.")
                      : "more than " + format_percent(tol, 2) + " worse, so the full sweep is worth its time.");
      out.push_back(rec);
    }
  }
  auto alphas = family(r, "sbvh_alpha");
  if (const KnobPoint* ref = reference_of(alphas)) {
    // Largest alpha (fewest splits, fastest) whose tree is at most `tol` worse.
    std::sort(alphas.begin(), alphas.end(), [](const KnobPoint* a, const KnobPoint* b) { return a->value > b->value; });
    const KnobPoint* chosen = ref;
    for (const KnobPoint* p : alphas)
      if (p->ops_error <= tol) {
        chosen = p;
        break;
      }
    Recommendation rec;
    rec.topic = "SBVH alpha";
    rec.setting = "--sbvh-alpha " + alpha(chosen->value);
    rec.why = "the largest alpha whose ops/ray is at most " + format_percent(tol, 2) + " above alpha=" + alpha(ref->value) +
              " (" + format_significant(ref->ops_per_ray) + " ops/ray, " + std::to_string(ref->references) +
              " references, build " + secs(ref->cpu_seconds) + " of CPU): " + format_significant(chosen->ops_per_ray) +
              " ops/ray, " + std::to_string(chosen->references) + " references, build " +
              secs(chosen->cpu_seconds) + " of CPU.";
    out.push_back(rec);
  }
}

void ao_recommendations(const AccuracyReport& r, std::vector<Recommendation>& out) {
  if (r.ao.size() < 2) return;
  const AoSamplesPoint& ref = r.ao.back();
  const double target = r.options.image_rmse_target;
  const AoSamplesPoint* image_choice = nullptr;
  for (const AoSamplesPoint& p : r.ao)
    if (!p.reference && p.image_rmse <= target) {
      image_choice = &p;
      break;
    }
  Recommendation image;
  image.topic = "AO rays per pixel, for pictures";
  const AoSamplesPoint& most = r.ao[r.ao.size() - 2];
  if (image_choice) {
    image.setting = "--ao " + std::to_string(image_choice->samples);
    image.why = "the fewest AO rays whose image RMSE (" + format_significant(image_choice->image_rmse, 3) +
                ") is at most " + format_significant(target, 3) + " against the " + std::to_string(ref.samples) +
                "-ray reference; the frame took " + secs(image_choice->cpu_seconds) + " of CPU vs " +
                secs(ref.cpu_seconds) + ".";
  } else {
    // Monte Carlo noise falls as 1/sqrt(n): extrapolate from the largest measured count.
    const uint32_t needed = uint32_t(std::ceil(most.samples * std::pow(most.image_rmse / target, 2.0)));
    image.setting = "--ao " + std::to_string(needed);
    image.why = "no measured count reached RMSE " + format_significant(target, 3) + " (" + std::to_string(most.samples) +
                " rays: " + format_significant(most.image_rmse, 3) + "); 1/sqrt(n) extrapolates to about " +
                std::to_string(needed) + " rays (the nested reference makes this an underestimate near " +
                std::to_string(ref.samples) + ").";
  }
  out.push_back(image);

  // For the counts, what matters is whether the AO rays' ops/ray is already stable.
  const AoSamplesPoint* counts_choice = &ref;
  for (size_t i = r.ao.size(); i-- > 0;) {
    if (!(std::fabs(r.ao[i].ao_ops_per_ray - ref.ao_ops_per_ray) <= r.options.tolerance * ref.ao_ops_per_ray)) break;
    counts_choice = &r.ao[i];
  }
  Recommendation counts;
  counts.topic = "AO rays per pixel, for ops/ray";
  counts.setting = "--ao " + std::to_string(counts_choice->samples);
  counts.why = "from " + std::to_string(counts_choice->samples) + " AO rays per pixel on, the AO rays' ops/ray (" +
               format_significant(counts_choice->ao_ops_per_ray) + ") stays within " + format_percent(r.options.tolerance, 2) +
               " of the " + std::to_string(ref.samples) + "-ray value (" + format_significant(ref.ao_ops_per_ray) +
               "); more rays only cost time. The combined ops/ray mixes primary and AO rays in the ratio 1:n, "
               "so compare it only at one AO count.";
  out.push_back(counts);
}

void resolution_recommendation(const AccuracyReport& r, std::vector<Recommendation>& out) {
  if (r.resolution.empty()) return;
  double worst = 0, spread_lo = HUGE_VAL, spread_hi = -HUGE_VAL;
  for (const ResolutionPoint& p : r.resolution)
    if (p.resolution == r.resolution_needed) {
      worst = std::max(worst, std::fabs(p.error));
      spread_lo = std::min(spread_lo, p.ops_per_ray);
      spread_hi = std::max(spread_hi, p.ops_per_ray);
    }
  const uint32_t highest = r.resolution.back().resolution;
  Recommendation rec;
  rec.topic = "rays per campaign job (resolution)";
  rec.setting = "--res " + std::to_string(r.resolution_needed) + "x" + std::to_string(r.resolution_needed);
  rec.why = std::to_string(r.resolution_needed) + "x" + std::to_string(r.resolution_needed) + " (" +
            std::to_string(r.rays_needed) + " rays per frame) is the smallest resolution from which every seed (" +
            std::to_string(r.options.seeds.size()) + " seeds) stays within " + format_percent(r.options.tolerance, 2) +
            " of the " + std::to_string(highest) + "x" + std::to_string(highest) + " mean (" +
            format_significant(r.resolution_reference_ops) + " ops/ray); worst there " + format_percent(worst) +
            ", seeds spread " + format_significant(spread_lo) + ".." + format_significant(spread_hi) + " ops/ray." +
            (r.resolution_needed == highest ? " Only the highest resolution qualified: the answer is a lower bound."
                                            : "");
  out.push_back(rec);
}

void traffic_recommendations(const AccuracyReport& r, std::vector<Recommendation>& out) {
  for (const TrafficVerdict& v : r.traffic_verdicts) {
    Recommendation rec;
    rec.topic = "memory traffic measurement (" + v.scene + ")";
    rec.setting = "--frames " + std::to_string(std::max<uint32_t>(2, v.frames_needed)) +
                  (v.resolution_converged ? " --res " + std::to_string(v.resolution_needed) + "x" +
                                                std::to_string(v.resolution_needed)
                                          : "");
    rec.why = v.summary +
              " Frames: stats are the last frame's, so at least 2 keep the cold first frame out of the "
              "figure (frames.frame1.* in stats.json still reports it).";
    out.push_back(rec);
  }
}

}  // namespace

std::vector<Recommendation> recommend(const AccuracyReport& report) {
  std::vector<Recommendation> out;
  fidelity_recommendations(report, out);
  knob_recommendations(report, out);
  ao_recommendations(report, out);
  resolution_recommendation(report, out);
  traffic_recommendations(report, out);
  return out;
}

}  // namespace rtsim
