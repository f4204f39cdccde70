#!/usr/bin/env bash
# Runs every libFuzzer target for a while: scripts/fuzz.sh [seconds-per-target] [target...]
# (default 60 s each, all targets). Builds them first (CMake preset "fuzz": clang,
# ASan + UBSan, into build-fuzz). Each target starts from its seeds (fuzz/seeds/<t>)
# and saved regressions (tests/fuzz-regressions/<t>) and grows a corpus in
# build-fuzz/corpus/<t>; a crash lands in build-fuzz/artifacts/<t>/. Prints one
# line per target (runs, exec/s, corpus size, findings) and exits 1 if any target
# found something. The longer run for a release: scripts/fuzz.sh 3600.
set -uo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
build=${RTSIM_FUZZ_BUILD_DIR:-build-fuzz}
jobs=${RTSIM_FUZZ_BUILD_JOBS:-$(nproc)}

if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DRTSIM_FUZZ=ON -DRTSIM_BUILD_TESTS=OFF -DRTSIM_BUILD_BENCH=OFF >/dev/null || exit 2
fi
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for source in fuzz/fuzz_*.cpp; do
    name=$(basename "$source" .cpp)
    targets+=("${name#fuzz_}")
  done
fi
cmake --build "$build" -j "$jobs" --target "${targets[@]/#/fuzz_}" >/dev/null || exit 2

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
found=0
printf '%-17s %6s %11s %7s %7s  %s\n' target seconds runs exec/s corpus findings
for t in "${targets[@]}"; do
  corpus="$build/corpus/$t"
  artifacts="$build/artifacts/$t"
  mkdir -p "$corpus" "$artifacts"
  seeds=()
  for dir in "fuzz/seeds/$t" "tests/fuzz-regressions/$t"; do
    [ -d "$dir" ] && seeds+=("$dir")
  done
  log="$build/fuzz-$t.log"
  # -timeout: an input taking > 10 s is a hang (a finding); -rss_limit_mb: so is 2 GB.
  "$build/fuzz/fuzz_$t" "$corpus" "${seeds[@]}" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 \
    -artifact_prefix="$artifacts/" >"$log" 2>&1
  rc=$?
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  size=$(find "$corpus" -type f | wc -l)
  findings=$(find "$artifacts" -type f | wc -l)
  status="none"
  if [ "$rc" -ne 0 ] || [ "$findings" -gt 0 ]; then
    status="$findings file(s) in $artifacts (exit $rc, log $log)"
    found=1
  fi
  printf '%-17s %6s %11s %7s %7s  %s\n' "$t" "$seconds" "${runs:-?}" "${rate:-?}" "$size" "$status"
done
exit $found
