#!/usr/bin/env bash
# Runs every libFuzzer target for a while: scripts/fuzz.sh [seconds-per-target] [target...]
# (default 60 s each, all targets, as many at once as there are cores).
#
# The targets live in the sanitizer build (CMake preset "asan": clang, ASan + UBSan,
# the libraries instrumented for libFuzzer, into build-asan), the same build whose
# tests scripts/test-sanitizers.sh runs; this script configures and builds what it
# needs of it. Each target starts from its seeds (fuzz/seeds/<t>)
# and saved regressions (tests/fuzz-regressions/<t>) and grows a corpus in
# <build>/fuzz-runs/corpus/<t>; a crash lands in <build>/fuzz-runs/artifacts/<t>/. Prints one
# line per target (seconds, runs, exec/s, corpus size, findings), the log of any
# target that found something, and exits 1 if any did.
#   RTSIM_FUZZ_JOBS=N     targets run at once (default: nproc)
#   RTSIM_FUZZ_SEED=N     libFuzzer's -seed, for a reproducible run (CI sets it)
#   RTSIM_FUZZ_BUILD_DIR  the build folder (default build-asan)
# The longer run before a release: scripts/fuzz.sh 3600.
set -uo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
case "$seconds" in
  '' | *[!0-9]*) echo "fuzz.sh: seconds-per-target must be a whole number, got '$seconds'" >&2; exit 2 ;;
esac
build=${RTSIM_FUZZ_BUILD_DIR:-build-asan}
jobs=${RTSIM_FUZZ_JOBS:-$(nproc)}

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for source in fuzz/fuzz_*.cpp; do
    name=$(basename "$source" .cpp)
    targets+=("${name#fuzz_}")
  done
fi
for t in "${targets[@]}"; do
  [ -f "fuzz/fuzz_$t.cpp" ] || { echo "fuzz.sh: no target '$t' (fuzz/fuzz_$t.cpp)" >&2; exit 2; }
done

if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake --preset asan -B "$build" >/dev/null || exit 2
fi
cmake --build "$build" -j "$(nproc)" --target "${targets[@]/#/fuzz_}" >/dev/null || exit 2

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
out="$build/fuzz-runs"
mkdir -p "$out"

# One target: its libFuzzer run, then a result line in $out/result-<t>.
run_target() {
  local t=$1 corpus="$out/corpus/$1" artifacts="$out/artifacts/$1" log="$out/fuzz-$1.log"
  mkdir -p "$corpus" "$artifacts"
  # Findings of this run are the artifacts newer than this marker; older ones stay.
  local started="$out/started-$t"
  touch "$started"
  local seeds=()
  for dir in "fuzz/seeds/$t" "tests/fuzz-regressions/$t"; do
    [ -d "$dir" ] && seeds+=("$dir")
  done
  # -timeout: an input taking > 10 s is a hang (a finding); -rss_limit_mb: so is 2 GB.
  "$build/fuzz/fuzz_$t" "$corpus" "${seeds[@]}" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 ${RTSIM_FUZZ_SEED:+-seed="$RTSIM_FUZZ_SEED"} \
    -artifact_prefix="$artifacts/" >"$log" 2>&1
  local rc=$?
  local runs rate size findings status="none"
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  size=$(find "$corpus" -type f | wc -l)
  findings=$(find "$artifacts" -type f -newer "$started" | wc -l)
  if [ "$rc" -ne 0 ] || [ "$findings" -gt 0 ]; then
    status="FOUND: $findings new file(s) in $artifacts (exit $rc, log $log)"
  fi
  printf '%-17s %7s %11s %7s %7s  %s\n' "$t" "$seconds" "${runs:-?}" "${rate:-?}" "$size" "$status" \
    >"$out/result-$t"
}

echo "fuzz.sh: ${#targets[@]} targets, $seconds s each, $jobs at once${RTSIM_FUZZ_SEED:+, seed $RTSIM_FUZZ_SEED}"
running=0
for t in "${targets[@]}"; do
  rm -f "$out/result-$t"
  run_target "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n
    running=$((running - 1))
  fi
done
wait

found=0
clean=0
printf '%-17s %7s %11s %7s %7s  %s\n' target seconds runs exec/s corpus findings
for t in "${targets[@]}"; do
  if [ ! -f "$out/result-$t" ]; then
    printf '%-17s  no result (the run did not finish)\n' "$t"
    found=$((found + 1))
    continue
  fi
  cat "$out/result-$t"
  if grep -q FOUND "$out/result-$t"; then found=$((found + 1)); else clean=$((clean + 1)); fi
done
if [ "$found" -ne 0 ]; then
  for t in "${targets[@]}"; do
    if [ ! -f "$out/result-$t" ] || grep -q FOUND "$out/result-$t"; then
      echo "---- $t: last lines of $out/fuzz-$t.log"
      tail -n 40 "$out/fuzz-$t.log"
    fi
  done
fi
echo "fuzz: $clean passed, $found failed"
[ "$found" -eq 0 ]
