#!/usr/bin/env bash
# trace --validate on every scene `rtsim scenes list` names (built-in and fetched),
# every builder, both cameras, at each resolution; prints the exact referee's
# counts per scene x builder x camera x resolution as a Markdown table and exits 1
# if the core was wrong on any ray.
#   scripts/validate-scenes.sh [rtsim] [resolutions...]   (default build/rtsim 64x64 256x256)
#   RTSIM_VALIDATE_SCENES="cornell dragon"  only these scenes
#   RTSIM_VALIDATE_BUILDERS="sah sbvh"      only these builders
#   RTSIM_VALIDATE_FORMATS="bvh2-64 bvh8-80q"  node formats (default bvh2-64)
#   RTSIM_VALIDATE_CAMERAS="view1"           cameras (default view1 view2)
# Trees are built once per scene x builder (x camera for osah) with `rtsim build
# --out` into a temporary folder and replayed with `trace --bvh`.
set -euo pipefail
cd "$(dirname "$0")/.."
rtsim=$(realpath "${1:-build/rtsim}")
shift || true
resolutions=("$@")
[ ${#resolutions[@]} -eq 0 ] && resolutions=(64x64 256x256)
export RTSIM_NO_PROGRESS=1
scenes=${RTSIM_VALIDATE_SCENES:-$("$rtsim" scenes list --json | python3 -c '
import json, sys
for s in json.load(sys.stdin)["scenes"]:
    if s["available"]: print(s["name"])')}
builders=${RTSIM_VALIDATE_BUILDERS:-$("$rtsim" build --list-builders)}
formats=${RTSIM_VALIDATE_FORMATS:-bvh2-64}
cameras=${RTSIM_VALIDATE_CAMERAS:-view1 view2}
work=$(mktemp -d /tmp/rtsim-validate.XXXXXX)
trap 'rm -rf "$work"' EXIT
printf '| scene | builder | format | camera | resolution | rays | disagreements | Embree wrong | core wrong | both admissible |\n'
printf '|---|---|---|---|---|---:|---:|---:|---:|---:|\n'
core_wrong_total=0
for scene in $scenes; do
  for builder in $builders; do
   for format in $formats; do
    for camera in $cameras; do
      tree="$work/$scene-$builder-$format.bvh"
      [ "$builder" = osah ] && tree="$work/$scene-$builder-$format-$camera.bvh"
      [ -f "$tree" ] || "$rtsim" build --scene "$scene" --builder "$builder" --camera "$camera" --no-epo \
        --node-format "$format" --out "$tree" >/dev/null
      for res in "${resolutions[@]}"; do
        set +e
        "$rtsim" trace --scene "$scene" --bvh "$tree" --node-format "$format" --camera "$camera" \
          --res "$res" --validate --json \
          >"$work/out.json" 2>"$work/err.txt"
        rc=$?
        set -e
        if [ "$rc" -ne 0 ] && [ "$rc" -ne 1 ]; then
          echo "validate-scenes: $scene $builder $format $camera $res: exit $rc: $(head -c 300 "$work/err.txt")" >&2
          exit 2
        fi
        line=$(python3 - "$work/out.json" <<'PY'
import json, sys
v = json.load(open(sys.argv[1]))["validate"]
print(v["rays"], v["disagreements"], v["embree_wrong"], v["core_wrong"], v["both_admissible"])
PY
)
        read -r rays dis ew cw ba <<<"$line"
        core_wrong_total=$((core_wrong_total + cw))
        printf '| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$scene" "$builder" "$format" "$camera" "$res" \
          "$rays" "$dis" "$ew" "$cw" "$ba"
      done
    done
   done
  done
  rm -f "$work"/*.bvh  # one scene's trees at a time
done
echo
echo "core wrong on $core_wrong_total rays in all"
[ "$core_wrong_total" -eq 0 ]
