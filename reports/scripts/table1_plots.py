#!/usr/bin/env python3
"""Pictures for `rtsim table1`: reductions per builder and camera, and the
ops-per-pixel heatmaps of every builder side by side on one colour scale.

Usage: table1_plots.py OUT_DIR   (reads OUT_DIR/table1.json and OUT_DIR/data/*.f32)
       table1_plots.py OUT_DIR --formats FORMAT...
                                 (reads OUT_DIR/FORMAT/table1.json; draws the reductions
                                  by node format into OUT_DIR/table1_formats.png)
"""
import json
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from plot_files import save  # noqa: E402

# The builders' display names come with the table (table1.json rows' display_name,
# from the registry), so the pictures and the tables name a tree alike.
NAMES = {}


def spread_of(row):
    """The combined ops/ray's 95% seed interval (lo, hi), or None for one tree."""
    s = (row.get("ops_per_ray_spread") or {}).get("combined")
    return (s["lo95"], s["hi95"]) if s else None


def others(builders, cam, base, ops):
    """The builders held against `base` on camera `cam`: present, and not base itself."""
    return [b for b in builders if b != base and (cam, b) in ops]


def reductions(table, cameras, builders, ops, spread, patent_red, out_dir):
    """Each builder's reduction of ops/ray against the median and SAH trees (never a
    tree against itself), the patent's against its BVH as hollow bars. Drawn only
    when the table compares something (table1.json "figures")."""
    compared = [b for b in builders if b != "median"]
    drawn = []
    fig, axes = plt.subplots(1, len(cameras), figsize=(6.5 * len(cameras), 5.2), squeeze=False)
    width = 0.27
    for ax, cam in zip(axes[0], cameras):
        x = np.arange(len(compared))
        for k, (base, colour) in enumerate((("median", "#4c72b0"), ("sah", "#dd8452"))):
            if (cam, base) not in ops or not others(builders, cam, base, ops):
                continue
            red = [100 * (1 - ops[(cam, b)] / ops[(cam, base)]) if b != base else np.nan for b in compared]
            # The seed spread of a sampled builder, as the reduction it spans.
            err = [[0.0] * len(compared), [0.0] * len(compared)]
            for i, b in enumerate(compared):
                if b != base and spread[(cam, b)]:
                    lo, hi = spread[(cam, b)]
                    err[0][i] = red[i] - 100 * (1 - hi / ops[(cam, base)])
                    err[1][i] = 100 * (1 - lo / ops[(cam, base)]) - red[i]
                if b != base:
                    drawn.append({"camera": cam, "builder": b, "baseline": base, "value": red[i]})
            ax.bar(x + (k - 1) * width, red, width, color=colour, label="ours vs %s" % NAMES[base],
                   yerr=err, capsize=2, error_kw={"linewidth": 0.8})
        if cam in patent_red:
            red = [100 * patent_red[cam].get(b, np.nan) for b in compared]
            ax.bar(x + width, red, width, fill=False, edgecolor="black", hatch="//",
                   label="patent vs its BVH")
        ax.axhline(0, color="black", linewidth=0.8)
        ax.set_xticks(x)
        ax.set_xticklabels([NAMES.get(b, b) for b in compared], rotation=20, ha="right", fontsize=8)
        ax.set_ylabel("reduction of TRV+IST ops/ray (%)")
        ax.set_title("camera %s" % cam)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.22), ncol=3)
    fig.suptitle("Table 1 on %s: reduction of TRV+IST operations per ray (higher is better; "
                 "bars: 95%% seed interval)" % table["scene"])
    save(fig, os.path.join(out_dir, "table1_reductions.png"),
         data={"figure": "table1_reductions", "drawn": drawn})


def main(out_dir):
    with open(os.path.join(out_dir, "table1.json")) as f:
        table = json.load(f)
    rows = table["rows"]
    NAMES.update({r["builder"]: r["display_name"] for r in rows})
    cameras = list(dict.fromkeys(r["camera"] for r in rows))
    builders = list(dict.fromkeys(r["builder"] for r in rows))
    ops = {(r["camera"], r["builder"]): r["combined"]["ops_per_ray"] for r in rows}
    spread = {(r["camera"], r["builder"]): spread_of(r) for r in rows}

    # Bar chart: reduction of ops/ray against each baseline, per camera; the
    # patent's reductions against its BVH as hollow bars for comparison.
    patent = table["patent"]
    patent_red = {}
    for i, cam in enumerate(cameras[:2]):
        key = "viewpoint%d" % (i + 1)
        base = patent["BVH"][key]
        # The patent's one AO-BVH beside each of our two readings of it.
        patent_red[cam] = {"sbvh": 1 - patent["SBVH"][key] / base,
                           "osah": 1 - patent["OSAH"][key] / base,
                           "aobvh": 1 - patent["AO-BVH"][key] / base,
                           "aosbvh": 1 - patent["AO-BVH"][key] / base}
    figures = table.get("figures", ["table1_reductions.png", "table1_heatmaps.png"])
    if "table1_reductions.png" in figures:
        reductions(table, cameras, builders, ops, spread, patent_red, out_dir)

    # Heatmaps: one shared colour scale (99th percentile over all) so that the
    # builders compare by eye.
    w, h = table["resolution"]
    maps = {}
    for cam in cameras:
        for b in builders:
            path = os.path.join(out_dir, "data", "ops_%s_%s.f32" % (cam, b))
            if os.path.exists(path):
                maps[(cam, b)] = np.fromfile(path, dtype=np.float32).reshape(h, w)
    if maps:
        vmax = float(np.percentile(np.concatenate([m.ravel() for m in maps.values()]), 99))
        fig, axes = plt.subplots(len(cameras), len(builders),
                                 figsize=(2.9 * len(builders), 2.9 * len(cameras) * h / w + 0.6),
                                 squeeze=False)
        image = None
        drawn = []
        for i, cam in enumerate(cameras):
            for j, b in enumerate(builders):
                ax = axes[i][j]
                ax.set_xticks([])
                ax.set_yticks([])
                if (cam, b) in maps:
                    image = ax.imshow(maps[(cam, b)], cmap="viridis", vmin=0, vmax=vmax)
                    drawn.append({"camera": cam, "builder": b, "value": ops[(cam, b)],
                                  "pixel_mean": float(maps[(cam, b)].mean())})
                    ax.set_title("%s, %s\n%.1f ops/ray" % (NAMES.get(b, b), cam, ops[(cam, b)]),
                                 fontsize=9)
        if image is not None:
            bar = fig.colorbar(image, ax=axes.ravel().tolist(), shrink=0.8)
            bar.set_label("TRV+IST ops per pixel (primary + its AO rays)")
        fig.suptitle("Ops per pixel on %s, one colour scale" % table["scene"])
        save(fig, os.path.join(out_dir, "table1_heatmaps.png"), data={"figure": "table1_heatmaps", "drawn": drawn})


def formats(out_dir, names):
    """AO-BVH's (and every builder's) reduction against SAH and SBVH per node format."""
    tables = []
    for name in names:
        with open(os.path.join(out_dir, name, "table1.json")) as f:
            tables.append(json.load(f))
    NAMES.update({r["builder"]: r["display_name"] for t in tables for r in t["rows"]})
    cameras = list(dict.fromkeys(r["camera"] for r in tables[0]["rows"]))
    builders = list(dict.fromkeys(r["builder"] for r in tables[0]["rows"]))
    ops = [{(r["camera"], r["builder"]): r["combined"]["ops_per_ray"] for r in t["rows"]} for t in tables]
    # The first row of panels: every builder's ops/ray in each format, which a
    # format study of one builder needs too. Then a row per baseline (SAH, SBVH)
    # that is there with other builders: their reductions against it, never its own.
    bases = [b for b in ("sah", "sbvh")
             if any(others(builders, cam, b, ops[0]) and (cam, b) in ops[0] for cam in cameras)]
    panels = [None] + bases
    fig, axes = plt.subplots(len(panels), len(cameras), figsize=(6.5 * len(cameras), 4 * len(panels)),
                             squeeze=False)
    width = 0.8 / max(1, len(names))
    drawn = []
    for col, cam in enumerate(cameras):
        for row, base in enumerate(panels):
            ax = axes[row][col]
            shown = builders if base is None else others(builders, cam, base, ops[0])
            x = np.arange(len(shown))
            for k, name in enumerate(names):
                if base is None:
                    values = [ops[k].get((cam, b), np.nan) for b in shown]
                else:
                    values = [100 * (1 - ops[k][(cam, b)] / ops[k][(cam, base)])
                              if (cam, b) in ops[k] and (cam, base) in ops[k] else np.nan for b in shown]
                for b, v in zip(shown, values):
                    drawn.append({"panel": "ops_per_ray" if base is None else "reduction_vs_" + base,
                                  "camera": cam, "builder": b, "format": name, "value": v})
                ax.bar(x + (k - (len(names) - 1) / 2) * width, values, width, label=name)
            ax.axhline(0, color="black", linewidth=0.8)
            ax.set_xticks(x)
            ax.set_xticklabels([NAMES.get(b, b) for b in shown])
            ax.set_ylabel("TRV+IST ops/ray" if base is None
                          else "reduction vs %s, same format (%%)" % NAMES.get(base, base))
            ax.set_title("camera %s" % cam)
            ax.grid(axis="y", alpha=0.3)
            ax.legend(fontsize=8, title="node format")
    fig.suptitle("Table 1 on %s by node format: TRV+IST ops/ray%s"
                 % (tables[0]["scene"], " and reductions (higher is better)" if bases else ""))
    save(fig, os.path.join(out_dir, "table1_formats.png"), data={"figure": "table1_formats", "drawn": drawn})


if __name__ == "__main__":
    if len(sys.argv) >= 4 and sys.argv[2] == "--formats":
        formats(sys.argv[1], sys.argv[3:])
    elif len(sys.argv) == 2:
        main(sys.argv[1])
    else:
        sys.exit(__doc__)
