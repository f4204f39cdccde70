#!/usr/bin/env bash
# AO-BVH's sampling knobs against what they cost: for each K (ao_rays) and sharing
# group G (ao_share), the tree's ops/ray on both cameras (mean and 95% interval over
# SEEDS builder seeds, functional level) and the AO rays the estimate casts (the
# build's cost that does not depend on the machine), with the estimate's seconds.
# Usage: scripts/ao-tradeoff.sh [SCENE...]   (default: interior)
#   RTSIM=build/rtsim SEEDS=5 KS="1 2 4 8 16" GS="1 4 16 64" RES=256x256
# Prints one TSV line per (scene, K, G); docs/builders.md quotes the table.
set -euo pipefail
rtsim=${RTSIM:-build/rtsim}
seeds=${SEEDS:-5}
ks=${KS:-"1 2 4 8 16"}
gs=${GS:-"1 4 16 64"}
res=${RES:-256x256}
scenes=("$@")
[ ${#scenes[@]} -eq 0 ] && scenes=(interior)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf 'scene\tK\tG\trays_per_triangle\testimate_s\tcamera\tops_per_ray\tci95\n'
for scene in "${scenes[@]}"; do
  for k in $ks; do
    for g in $gs; do
      RTSIM_NO_PROGRESS=1 "$rtsim" build --scene "$scene" --builder aobvh --ao-rays "$k" --ao-share "$g" \
        --no-epo --json > "$tmp/build.json"
      RTSIM_NO_PROGRESS=1 "$rtsim" table1 --scene "$scene" --no-cycle --builders aobvh --build-seeds "$seeds" \
        --res "$res" --build-set "ao_rays=$k" --build-set "ao_share=$g" --out-dir "$tmp/t" > /dev/null 2>&1
      python3 - "$tmp/build.json" "$tmp/t/table1.json" "$scene" "$k" "$g" <<'PY'
import json, sys
build = json.load(open(sys.argv[1]))
tree = build["trees"][0]
table = json.load(open(sys.argv[2]))
for row in table["rows"]:
    s = row["ops_per_ray_spread"]["combined"]
    half = (s["hi95"] - s["lo95"]) / 2 if s else 0.0
    print("%s\t%s\t%s\t%.3f\t%.3f\t%s\t%.3f\t%.3f" % (
        sys.argv[3], sys.argv[4], sys.argv[5], tree["ao_rays"] / build["triangles"],
        tree["estimate_seconds"], row["camera"], row["combined"]["ops_per_ray"], half))
PY
    done
  done
done
