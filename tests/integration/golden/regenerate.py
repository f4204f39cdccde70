#!/usr/bin/env python3
"""Writes the golden stats again after a rename, never after a change of value.

Usage: tests/integration/golden/regenerate.py build/rtsim

Runs the six runs of tests/integration/test_machine.cpp (OneCore.*) with that
binary and rewrites mobile-<run>.tsv: every key the file holds, renamed by RENAMED
(a key the model no longer writes must be listed there), with its value from the
run, plus the keys of ADDED_PATTERNS. A kept key whose value differs from the
stored one stops the script with the list of differences: the golden files hold
the single-accelerator model's numbers, and a rename must leave them as they were.
A replaced key's parts must add up to its stored value (REPLACED).
"""
import json
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = {  # as in test_machine.cpp
    "cornell-functional": ("--scene cornell --res 40x40 --fidelity functional", True),
    "cornell-lt": ("--scene cornell --res 40x40 --fidelity lt", True),
    "cornell-cycle": ("--scene cornell --res 40x40 --fidelity cycle", True),
    "interior-functional": ("--scene interior --res 32x32 --frames 2 --fidelity functional", False),
    "interior-lt": ("--scene interior --res 32x32 --frames 2 --fidelity lt", False),
    "interior-cycle": ("--scene interior --res 32x32 --frames 2 --fidelity cycle", False),
}
# Issue 35: the overlapping "stalled" counters went; raygen's is a blocked count.
RENAMED = {r"(core\d+)\.raygen\.stalled_cycles": r"\1.raygen.blocked_cycles"}
# A unit's waiting_cycles is now split exclusively; the parts its kind has must add up to it.
WAITING_PARTS = ["waiting_l1", "waiting_noc", "waiting_l2", "waiting_dram", "blocked", "waiting_ist", "latency"]
REPLACED = {r"(.+)\.waiting_cycles": [r"\1." + p + "_cycles" for p in WAITING_PARTS]}
REMOVED = [r".+\.(trv|ist|shading)\d*\.stalled_cycles"]  # overlapped busy and waiting
ADDED_PATTERNS = [r"core\d+\.(trv|ist)\d+\.[a-z_0-9]+_cycles", r"core\d+\.shading\.[a-z_]+_cycles"]


def flatten(node, prefix, out):
    if isinstance(node, dict) and "value" in node and "unit" in node:
        out[prefix] = node["value"]
        return
    for key, value in node.items():
        flatten(value, prefix + "." + key if prefix else key, out)


def run(binary, name, args, scanline, folder):
    config = os.path.join(folder, name + ".toml")
    with open(config, "w") as f:
        f.write('preset = "mobile"\ncores = 1\n' + ('raygen.order = "scanline"\n' if scanline else ""))
    out = os.path.join(folder, name)
    subprocess.run([binary, "simulate"] + args.split() + ["--config", config, "--out-dir", out],
                   check=True, stdout=subprocess.DEVNULL)
    stats = {}
    with open(os.path.join(out, "stats.json")) as f:
        flatten(json.load(f), "", stats)
    with open(os.path.join(out, "config.json")) as f:
        scene_hash = json.load(f)["inputs"]["scene_hash"]
    return stats, scene_hash


def main():
    binary = os.path.abspath(sys.argv[1])
    problems = []
    with tempfile.TemporaryDirectory() as folder:
        for name, (args, scanline) in RUNS.items():
            path = os.path.join(HERE, "mobile-%s.tsv" % name)
            with open(path) as f:
                lines = f.read().splitlines()
            header, stored = lines[0], [line.split("\t") for line in lines[1:]]
            stats, scene_hash = run(binary, name, args, scanline, folder)
            if header != "# scene_hash\t" + scene_hash:
                problems.append("%s: this build makes scene %s, the file holds %s" % (name, scene_hash, header))
                continue
            keys = []
            for key, text in stored:
                value = json.loads(text)
                if any(re.fullmatch(p, key) for p in REMOVED):
                    continue
                replaced = [(p, parts) for p, parts in REPLACED.items() if re.fullmatch(p, key)]
                if replaced:
                    pattern, parts = replaced[0]
                    total = sum(stats.get(re.sub(pattern, part, key), 0) for part in parts)
                    if total != value:
                        problems.append("%s: the parts of %s add up to %s, it was %s" % (name, key, total, value))
                    continue
                new_key = key
                for pattern, target in RENAMED.items():
                    new_key = re.sub("^" + pattern + "$", target, new_key)
                if new_key not in stats:
                    problems.append("%s: %s (was %s) is not written any more" % (name, new_key, key))
                elif stats[new_key] != value:
                    problems.append("%s: %s is %r, it was %r" % (name, new_key, stats[new_key], value))
                keys.append(new_key)
            keys += [k for k in stats if k not in keys and any(re.fullmatch(p, k) for p in ADDED_PATTERNS)]
            with open(path + ".new", "w") as f:
                f.write(header + "\n")
                for key in sorted(keys):
                    f.write("%s\t%s\n" % (key, json.dumps(stats[key])))
    if problems:
        for p in problems:
            print(p, file=sys.stderr)
        for name in RUNS:
            new = os.path.join(HERE, "mobile-%s.tsv.new" % name)
            if os.path.exists(new):
                os.remove(new)
        sys.exit(1)
    for name in RUNS:
        path = os.path.join(HERE, "mobile-%s.tsv" % name)
        os.replace(path + ".new", path)
    print("golden stats rewritten: every kept value as it was")


if __name__ == "__main__":
    main()
