#!/usr/bin/env bash
# Two bench_trace binaries (before and after a change) run in turn, ROUNDS rounds,
# so that the machine's neighbours weigh on both alike; prints each benchmark's best
# Mrays/s for both, their ratio, and each core row's ratio to Embree's BVH8 from the
# same binary's rounds (docs/build-speed.md's tables).
#   scripts/bench-trace-in-turn.sh BEFORE AFTER [ROUNDS] [FILTER]
# ROUNDS defaults to 4, FILTER to every core row and Embree's BVH8; RTSIM_CACHE as
# for bench_trace (dragon is measured when fetched); MIN_TIME per benchmark, 0.25 s.
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: $0 BEFORE AFTER [ROUNDS] [FILTER]" >&2
  exit 2
fi
before=$1 after=$2 rounds=${3:-4} filter=${4:-'^core_|bvh8/'}
for exe in "$before" "$after"; do
  [[ -x $exe ]] || { echo "$0: $exe: not an executable bench_trace" >&2; exit 2; }
done
[[ $rounds =~ ^[1-9][0-9]*$ ]] || { echo "$0: ROUNDS: '$rounds' is not a positive whole number" >&2; exit 2; }
runs=$(mktemp -d)
trap 'rm -rf "$runs"' EXIT
for ((r = 1; r <= rounds; ++r)); do
  for side in before after; do
    exe=$before
    [[ $side == after ]] && exe=$after
    echo "round $r/$rounds: $side" >&2
    "$exe" --benchmark_filter="$filter" --benchmark_min_time="${MIN_TIME:-0.25}" \
      --benchmark_format=json >"$runs/$side.$r.json"
  done
done
python3 - "$runs" "$rounds" <<'PY'
import json, sys
runs, rounds = sys.argv[1], int(sys.argv[2])
best = {}
for side in ("before", "after"):
    for r in range(1, rounds + 1):
        for b in json.load(open(f"{runs}/{side}.{r}.json"))["benchmarks"]:
            key = (side, b["name"])
            best[key] = max(best.get(key, 0.0), b["items_per_second"])
names = sorted({n for _, n in best}, key=lambda n: ("dragon" in n, n))
def embree(name, side):  # core_<kind>/<scene>/<format> -> Embree's BVH8 for that kind and scene
    kind, scene = name.split("/")[0][len("core_"):], name.split("/")[1]
    call = "embree_occluded1_bvh8/" if kind == "ao" else "embree_intersect1_bvh8/"
    return best.get((side, call + scene))
print(f"{'benchmark':40s} {'before':>8s} {'after':>8s} {'after/before':>12s}  Embree BVH8 ratio")
for n in names:
    a, b = best.get(("before", n)), best.get(("after", n))
    if a is None or b is None:
        continue
    line = f"{n:40s} {a / 1e6:8.3f} {b / 1e6:8.3f} {b / a:12.3f}"
    if n.startswith("core_") and embree(n, "before") and embree(n, "after"):
        line += f"  {a / embree(n, 'before'):.2f} -> {b / embree(n, 'after'):.2f}"
    print(line)
PY
