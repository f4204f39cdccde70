#pragma once
// A fake `rtsim` for the campaign tests: answers --version and `simulate ... --out DIR`
// by writing DIR/config.json and DIR/stats.json with numbers derived from its
// arguments (deterministic), so the campaign machinery (store, resume, kill -9,
// collect) is tested without depending on the simulator's speed or state.
// Knobs (environment): FAKE_SLEEP seconds per job, FAKE_FAIL_BUILDER makes every job
// of that builder fail, FAKE_LOG gets one line per started job (its --out folder),
// FAKE_REVISION the revision --version reports, FAKE_HOLD_UNTIL a file each job
// waits for before it finishes.
#include <rtsim/reports/campaign.h>

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace rtsim::test {

inline const char* kFakeRtsim = R"fake(#!/bin/bash
if [ "$1" = "--version" ]; then echo "fake 0.0 (${FAKE_REVISION:-fakerev1})"; exit 0; fi
if [ "$1" != "simulate" ]; then echo "fake: unknown command $1" >&2; exit 2; fi
shift
out=""; builder=""; preset=""; scene=""; seed=1; sets=""; sleep_s="${FAKE_SLEEP:-0}"
while [ $# -gt 0 ]; do
  case "$1" in
    --out|--out-dir) out="$2";; --builder) builder="$2";; --config) preset="$2";;
    --scene) scene="$2";; --seed) seed="$2";;
    --set) sets="$sets $2";;
  esac
  shift 2
done
[ -n "$FAKE_LOG" ] && echo "$out" >> "$FAKE_LOG"
echo "fake: simulating $scene $builder $preset"
sleep "$sleep_s"
# FAKE_HOLD_UNTIL: the job waits until that file exists (a test's "go"), so that a
# test can act while jobs are certainly running, whatever the load.
if [ -n "$FAKE_HOLD_UNTIL" ]; then
  while [ ! -e "$FAKE_HOLD_UNTIL" ]; do sleep 0.02; done
fi
if [ -n "$FAKE_FAIL_BUILDER" ] && [ "$builder" = "$FAKE_FAIL_BUILDER" ]; then
  echo "fake: builder $builder refused on purpose" >&2; exit 3
fi
# A hardware file (campaign overrides) counts by content, not by its path.
hardware="$preset"; l2=524288
if [ -f "$preset" ]; then
  hardware=$(grep -v '^#' "$preset")
  l2=$(sed -n '/^\[l2\]/,/^\[/p' "$preset" | sed -n 's/^size_bytes = //p'); l2=${l2:-524288}
fi
n=$(printf '%s|%s|%s|%s|%s' "$scene" "$builder" "$hardware" "$seed" "$sets" | cksum | cut -d' ' -f1)
rays=4096
cycles=$((200000 + n % 100000)); trv=$((60000 + n % 9000)); ist=$((20000 + n % 7000))
dram=$((300000 + n % 200000)); hits=$((n % 900)); l2hits=$((n % 500))
leaf() { printf '{"value": %s, "unit": "%s", "description": "%s"}' "$1" "$2" "$3"; }
cat > "$out/stats.json.tmp" <<EOF
{"rays": {"total": $(leaf $rays rays "rays traced")},
 "time": {"cycles": $(leaf $cycles cycles "simulated cycles")},
 "ops": {"trv": $(leaf $trv ops "TRV ops"), "ist": $(leaf $ist ops "IST ops")},
 "fetches": {"node": $(leaf $trv fetches "node fetches"), "triangle": $(leaf $ist fetches "triangle fetches")},
 "l1_node": {"all": {"accesses": $(leaf 1000 requests "a"), "hits": $(leaf $hits requests "h")}},
 "l1_triangle": {"all": {"hit_rate": $(leaf 0.$((hits / 2 + 100)) ratio "h")}},
 "l2": {"accesses": $(leaf 500 requests "a"), "hits": $(leaf $l2hits requests "h")},
 "dram": {"bytes": $(leaf $dram bytes "DRAM bytes"),
          "bytes_by_type": {"primary": {"node": $(leaf $((dram / 4)) bytes "x"), "triangle": $(leaf $((dram / 8)) bytes "x")},
                       "ao": {"node": $(leaf $((dram / 2)) bytes "x"), "triangle": $(dram_rest=$((dram - dram / 4 - dram / 8 - dram / 2)); leaf $dram_rest bytes "x")}}}}
EOF
mv "$out/stats.json.tmp" "$out/stats.json"
printf '{"rays_per_host_second": {"value": 123456.5, "unit": "rays/s", "description": "d"}}\n' > "$out/host.json"
printf '{"git_revision": "%s", "seed": %s, "builder": "%s", "hardware": {"l2": {"size_bytes": %s}}}\n' "${FAKE_REVISION:-fakerev1}" "$seed" "$builder" "$l2" > "$out/config.json"
exit 0
)fake";

// A fresh folder under the test temp dir, named after the running test.
inline std::filesystem::path fresh_folder(const std::string& tag) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path dir = std::filesystem::temp_directory_path() /
                              ("rtsim-campaign-" + std::string(info->name()) + "-" + tag + "-" +
                               std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline std::filesystem::path write_fake_rtsim(const std::filesystem::path& dir) {
  const std::filesystem::path p = dir / "fake-rtsim";
  std::ofstream(p) << kFakeRtsim;
  ::chmod(p.c_str(), 0755);
  return p;
}

inline std::filesystem::path write_text(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p) << text;
  return p;
}

// Runs a shell command, returns its exit code (-1 if it did not exit normally).
inline int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

inline std::vector<std::string> read_lines(const std::filesystem::path& p) {
  std::vector<std::string> lines;
  std::ifstream in(p);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(line);
  return lines;
}

// A campaign of `builders` x `presets` x `seeds` fake jobs.
inline std::string small_campaign(const std::string& name, int seeds) {
  std::ostringstream s;
  s << "[campaign]\nname = \"" << name << "\"\n[sweep]\nscene = \"interior\"\n"
    << "builder = [\"sah\", \"aobvh\"]\npreset = [\"mobile\", \"desktop\"]\n"
    << "seed = {from = 1, to = " << seeds << ", step = 1}\n";
  return s.str();
}

}  // namespace rtsim::test
