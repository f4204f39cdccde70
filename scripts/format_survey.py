#!/usr/bin/env python3
"""Node formats x builders x scenes: tree size, operation counts, fetches, DRAM
traffic and cycles, as one Markdown table (the node-format issue's survey).

  scripts/format_survey.py [--rtsim build/rtsim] [--scenes interior dragon]
      [--builders sah sbvh aobvh embree] [--formats bvh2-64 bvh4-128 bvh8-80q]
      [--res 128x128] [--fidelity cycle] [--config mobile] [--frames 1] [--json OUT]

For each (scene, builder, format) it runs `rtsim build --node-format F --out T`
(SAH cost, nodes, node bytes per triangle) and `rtsim simulate --bvh T
--node-format F` (stats.json), in a temporary folder it removes afterwards.
Per-ray figures count every ray (primary and AO).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def stat(stats, path):
    node = stats
    for part in path.split("."):
        node = node[part]
    return node["value"]


def run(cmd):
    done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit("format_survey: %s failed (%d): %s" % (" ".join(cmd), done.returncode,
                                                        done.stderr.strip()[-500:]))
    return done.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rtsim", default="build/rtsim")
    ap.add_argument("--scenes", nargs="+", default=["interior"])
    ap.add_argument("--builders", nargs="+", default=["sah", "sbvh", "aobvh", "embree"])
    ap.add_argument("--formats", nargs="+", default=["bvh2-64", "bvh4-128", "bvh4-64h", "bvh6-64q", "bvh8-80q"])
    ap.add_argument("--res", default="128x128")
    ap.add_argument("--fidelity", default="cycle")
    ap.add_argument("--config", default="mobile")
    ap.add_argument("--frames", default="1")
    ap.add_argument("--json", help="also write every row as JSON here")
    a = ap.parse_args()
    env = dict(os.environ, RTSIM_NO_PROGRESS="1")
    os.environ.update(env)
    rows = []
    head = ("| scene | builder | format | nodes | node B/tri | SAH cost | TRV/ray | box tests/ray | "
            "IST/ray | node fetches/ray | node B/ray | DRAM B/ray | cycles |")
    print(head)
    print("|" + "---|" * 3 + "---:|" * 10)
    with tempfile.TemporaryDirectory(prefix="rtsim-formats.") as work:
        for scene in a.scenes:
            for builder in a.builders:
                for fmt in a.formats:
                    tree = os.path.join(work, "tree.bvh")
                    built = json.loads(run([a.rtsim, "build", "--scene", scene, "--builder", builder,
                                            "--node-format", fmt, "--no-epo", "--json", "--out", tree]))
                    t = built["trees"][0]
                    out = os.path.join(work, "run")
                    run([a.rtsim, "simulate", "--scene", scene, "--bvh", tree, "--node-format", fmt,
                         "--fidelity", a.fidelity, "--config", a.config, "--res", a.res,
                         "--frames", a.frames, "--out-dir", out])
                    with open(os.path.join(out, "stats.json")) as f:
                        s = json.load(f)
                    rays = stat(s, "rays.total")
                    node_fetches = stat(s, "fetches.node")
                    record = stat(s, "memory.node_bytes") / max(1, stat(s, "memory.node_records"))
                    row = {
                        "scene": scene, "builder": builder, "format": fmt, "nodes": t["nodes"],
                        "node_bytes_per_triangle": t["node_bytes_per_triangle"], "sah_cost": t["sah_cost"],
                        "trv_per_ray": stat(s, "ops.trv") / rays, "box_tests_per_ray": stat(s, "ops.box_tests") / rays,
                        "ist_per_ray": stat(s, "ops.ist") / rays, "node_fetches_per_ray": node_fetches / rays,
                        "node_bytes_per_ray": node_fetches * record / rays,
                        "dram_bytes_per_ray": stat(s, "dram.bytes_per_ray"), "cycles": stat(s, "time.cycles"),
                        "rays": rays,
                    }
                    rows.append(row)
                    print("| %s | %s | %s | %d | %.2f | %.3f | %.2f | %.2f | %.2f | %.2f | %.1f | %.2f | %d |" % (
                        scene, builder, fmt, row["nodes"], row["node_bytes_per_triangle"], row["sah_cost"],
                        row["trv_per_ray"], row["box_tests_per_ray"], row["ist_per_ray"],
                        row["node_fetches_per_ray"], row["node_bytes_per_ray"], row["dram_bytes_per_ray"],
                        row["cycles"]), flush=True)
    if a.json:
        tmp = a.json + ".tmp"
        with open(tmp, "w") as f:
            json.dump(rows, f, indent=1)
        os.replace(tmp, a.json)


if __name__ == "__main__":
    main()
