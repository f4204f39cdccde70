#!/usr/bin/env python3
"""Picture for `rtsim accuracy`: the trade-off curves, error against time on log
scales, one panel per knob.

Usage: accuracy_plots.py OUT_DIR   (reads OUT_DIR/accuracy.json, writes
OUT_DIR/accuracy_tradeoffs.png)
"""
import json
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402
from plot_files import save  # noqa: E402

LEVEL_STYLE = {"functional": ("#4c72b0", "o"), "lt": ("#dd8452", "s"), "cycle": ("#55a868", "^")}



def readable_log(ax, which="both"):
    """Log axes label only whole decades by default; a span under a decade then shows
    a single number. Label 1, 2 and 5 of every decade, in plain notation."""
    axes = [ax.xaxis, ax.yaxis] if which == "both" else [ax.xaxis if which == "x" else ax.yaxis]
    for axis in axes:
        axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: "%g" % v))
        axis.set_minor_formatter(NullFormatter())


def floor_of(values, default=1e-4):
    """Zero errors (a reference against itself) cannot sit on a log axis: draw them
    on a floor a decade below the smallest non-zero error and say so."""
    positive = [v for v in values if v > 0]
    return (min(positive) / 10) if positive else default


def on_floor(v, floor):
    return v if v > 0 else floor


def fidelity_panel(ax, data, x_key, x_label):
    points = data.get("fidelity", [])
    errors = [abs(p["cycle_error"]) * 100 for p in points] + [abs(p["dram_error"]) * 100 for p in points]
    floor = floor_of(errors, 1e-3)
    # One line per level and scene: a line never joins two scenes' points.
    scenes = []
    for p in points:
        if p.get("scene", "") not in scenes:
            scenes.append(p.get("scene", ""))
    for level, (colour, marker) in LEVEL_STYLE.items():
        for si, scene in enumerate(scenes):
            mine = [p for p in points if p["level"] == level and p.get("scene", "") == scene]
            if not mine:
                continue
            xs = [p[x_key] for p in mine]
            ax.plot(xs, [on_floor(abs(p["cycle_error"]) * 100, floor) for p in mine], marker=marker, color=colour)
            ax.plot(xs, [on_floor(abs(p["dram_error"]) * 100, floor) for p in mine], marker=marker, color=colour,
                    linestyle="--", markerfacecolor="none")
            for i, (p, x) in enumerate(zip(mine, xs)):
                # The reference level sits on the floor line: with one scene its labels
                # are staggered upwards, with several only each scene's last point is
                # named, one row a scene.
                if level == "cycle" and len(scenes) > 1 and i != len(mine) - 1:
                    continue
                dy = 4 + 9 * (si if len(scenes) > 1 else i) if level == "cycle" else 4
                label = "%d²" % p["resolution"]
                if len(scenes) > 1 and i == len(mine) - 1:
                    label = "%s %s" % (scene, label)
                ax.annotate(label, (x, on_floor(abs(p["cycle_error"]) * 100, floor)),
                            textcoords="offset points", xytext=(4, dy), fontsize=7, color=colour)
    ax.axhline(floor, color="grey", linewidth=0.6, linestyle=":")
    ax.text(0.02, 0.02, "bottom line: error 0 (cycle is the reference)", transform=ax.transAxes,
            fontsize=7, color="grey")
    tol = data["tolerances"]["cycles_and_dram"] * 100
    ax.axhline(tol, color="red", linewidth=0.8, linestyle=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    readable_log(ax)
    ax.margins(x=0.15, y=0.15)
    ax.set_xlabel(x_label)
    ax.set_ylabel("|error| vs cycle level (%)")
    handles = [Line2D([], [], color=c, marker=m, linestyle="none", label=level)
               for level, (c, m) in LEVEL_STYLE.items()]
    handles += [Line2D([], [], color="black", label="cycles"),
                Line2D([], [], color="black", linestyle="--", marker="o", markerfacecolor="none",
                       label="DRAM bytes"),
                Line2D([], [], color="red", linestyle=":", label="tolerance %.3g%%" % tol)]
    ax.legend(handles=handles, fontsize=7, ncol=2, loc="best", framealpha=0.9)


def k_panel(ax, data):
    ks = [k for k in data.get("knobs", []) if k["family"] == "ao_rays"]
    if not ks:
        ax.set_visible(False)
        return
    # The reference K has error 0 by definition: it appears in the ops/ray series only.
    measured = [k for k in ks if not k["reference"]]
    ref = next((k for k in ks if k["reference"]), None)
    ref_name = ref["setting"] if ref else "reference"
    rmse = [k["occlusion_rmse"] for k in measured]
    floor = floor_of(rmse)
    ax.plot([k["cpu_seconds"] for k in measured], [on_floor(v, floor) for v in rmse], marker="o",
            color="#4c72b0", label="occlusion RMSE vs %s" % ref_name)
    for k, v in zip(measured, rmse):
        ax.annotate(k["setting"], (k["cpu_seconds"], on_floor(v, floor)), textcoords="offset points",
                    xytext=(4, 4), fontsize=7)
    # Shared estimates (G triangles per K-ray estimate), against the same reference.
    shares = [k for k in data.get("knobs", []) if k["family"] == "ao_share"]
    if shares:
        srmse = [k["occlusion_rmse"] for k in shares]
        ax.plot([k["cpu_seconds"] for k in shares], [on_floor(v, floor) for v in srmse], marker="^",
                color="#55a868", label="shared estimates, RMSE")
        for k, v in zip(shares, srmse):
            ax.annotate(k["setting"].split(" ")[0], (k["cpu_seconds"], on_floor(v, floor)),
                        textcoords="offset points", xytext=(4, -10), fontsize=7, color="#55a868")
    xs = [k["cpu_seconds"] for k in ks]
    ax.set_xscale("log")
    ax.set_yscale("log")
    readable_log(ax)
    ax.margins(x=0.1, y=0.1)
    ax.set_xlabel("AO estimate + build, CPU time (s)")
    ax.set_ylabel("per-triangle occlusion RMSE")
    twin = ax.twinx()
    twin.plot(xs, [k["ops_per_ray"] for k in ks], marker="s", color="#c44e52", linestyle="--",
              label="tree ops/ray (right; last point %s)" % ref_name)
    if shares:
        twin.plot([k["cpu_seconds"] for k in shares], [k["ops_per_ray"] for k in shares], marker="v",
                  color="#8c613c", linestyle=":", label="shared: tree ops/ray (right)")
    twin.set_ylabel("TRV+IST ops/ray", color="#c44e52")
    twin.tick_params(axis="y", colors="#c44e52")
    lines = ax.get_legend_handles_labels()
    more = twin.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=7, loc="upper center")
    ax.set_title("AO-BVH: AO rays per primitive K, shared by G (reference %s)" % ref_name, fontsize=10)


def builder_panel(ax, data):
    shown = False
    for family, colour, name in (("sah_bins", "#4c72b0", "SAH bins"), ("sbvh_alpha", "#dd8452", "SBVH alpha")):
        pts = [k for k in data.get("knobs", []) if k["family"] == family]
        if not pts:
            continue
        shown = True
        xs = [k["cpu_seconds"] for k in pts]
        ax.plot(xs, [k["ops_per_ray"] for k in pts], marker="o", color=colour, label=name)
        for i, (k, x) in enumerate(zip(pts, xs)):
            text = k["setting"] + (", %d refs" % k["references"] if family == "sbvh_alpha" else "")
            # Staggered so that settings giving the same tree do not print over each other.
            ax.annotate(text, (x, k["ops_per_ray"]), textcoords="offset points", xytext=(5, 4 + 11 * i),
                        fontsize=7, color=colour)
    if not shown:
        ax.set_visible(False)
        return
    ax.set_xscale("log")
    readable_log(ax, "x")
    ax.set_xlabel("build, CPU time (s)")
    ax.set_ylabel("TRV+IST ops/ray (lower is better)")
    ax.legend(fontsize=7)
    ax.margins(x=0.25, y=0.2)
    ax.set_title("SAH binning and SBVH alpha", fontsize=10)


def ao_panel(ax, data):
    pts = [p for p in data.get("ao_rays_per_pixel", []) if not p["reference"]]
    if not pts:
        ax.set_visible(False)
        return
    xs = [p["cpu_seconds"] for p in pts]
    ys = [p["image_rmse"] for p in pts]
    floor = floor_of(ys)
    ax.plot(xs, [on_floor(v, floor) for v in ys], marker="o", color="#55a868", label="AO image RMSE")
    for p, x, y in zip(pts, xs, ys):
        ax.annotate("%d rays" % p["samples"], (x, on_floor(y, floor)), textcoords="offset points",
                    xytext=(4, 4), fontsize=7)
    # 1/sqrt(n) through the first point: what Monte Carlo noise alone predicts.
    n0, e0 = pts[0]["samples"], ys[0]
    if e0 > 0:
        ax.plot(xs, [e0 * (n0 / p["samples"]) ** 0.5 for p in pts], color="grey", linestyle=":",
                label="1/sqrt(n) from the first point")
    target = data["tolerances"]["ao_image_rmse"]
    ax.axhline(target, color="red", linewidth=0.8, linestyle=":", label="target %.3g" % target)
    ax.set_xscale("log")
    ax.set_yscale("log")
    readable_log(ax)
    ax.set_xlabel("frame CPU time, functional core (s)")
    ax.set_ylabel("RMSE vs %d-ray image" % data["ao_rays_per_pixel"][-1]["samples"])
    ax.legend(fontsize=7)
    ax.set_title("AO rays per pixel", fontsize=10)


def resolution_panel(ax, data):
    res = data.get("resolution", {})
    pts = res.get("points", [])
    if not pts:
        ax.set_visible(False)
        return
    errors = [abs(p["error"]) * 100 for p in pts]
    floor = floor_of(errors, 1e-3)
    seeds = sorted(set(p["seed"] for p in pts))
    for i, seed in enumerate(seeds):
        mine = [p for p in pts if p["seed"] == seed]
        ax.plot([p["rays"] for p in mine], [on_floor(abs(p["error"]) * 100, floor) for p in mine],
                marker="o", linewidth=0.8, alpha=0.8, label="seed %d" % seed)
    for r in sorted(set(p["resolution"] for p in pts)):
        mine = [q for q in pts if q["resolution"] == r]
        top = max(on_floor(abs(q["error"]) * 100, floor) for q in mine)
        ax.annotate("%d²" % r, (mine[0]["rays"], top), textcoords="offset points", xytext=(0, 6), fontsize=7,
                    ha="center", color="grey")
    tol = res.get("tolerance", 0.01) * 100
    ax.axhline(tol, color="red", linewidth=0.8, linestyle=":", label="%.3g%% tolerance" % tol)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: "%g" % v))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("rays per frame (primary + AO)")
    ax.set_ylabel("|ops/ray - highest-res mean| (%)")
    ax.legend(fontsize=7)
    ax.set_title("Resolution: ops/ray stability (needed: %d², %d rays)"
                 % (res.get("resolution_needed", 0), res.get("rays_needed", 0)), fontsize=10)


def main(out_dir):
    with open(os.path.join(out_dir, "accuracy.json")) as f:
        data = json.load(f)
    fig, axes = plt.subplots(2, 3, figsize=(17, 10))
    fidelity_panel(axes[0][0], data, "cpu_seconds", "simulation CPU time (s)")
    axes[0][0].set_title("Fidelity levels: error vs time", fontsize=10)
    fidelity_panel(axes[0][1], data, "rays_per_cpu_second", "simulated rays per CPU second")
    axes[0][1].set_title("Fidelity levels: error vs throughput", fontsize=10)
    k_panel(axes[0][2], data)
    builder_panel(axes[1][0], data)
    ao_panel(axes[1][1], data)
    resolution_panel(axes[1][2], data)
    for ax in axes.ravel():
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("What accuracy costs in time on %s (%d triangles)%s; times are process CPU seconds"
                 % (data["scene"], data["triangles"], ", quick sizes" if data.get("quick") else ""))
    fig.tight_layout()
    save(fig, os.path.join(out_dir, "accuracy_tradeoffs.png"))
    ao_images(out_dir, data)
    traffic(out_dir, data)


def traffic(out_dir, data):
    """DRAM bytes and cycles per ray against resolution: cold first frame vs steady state."""
    points = data.get("traffic", {}).get("points", [])
    if not points:
        return
    scenes = sorted({p["scene"] for p in points}, key=[p["scene"] for p in points].index)
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, scene in enumerate(scenes):
        colour = colours[i % len(colours)]
        fn = sorted((p for p in points if p["scene"] == scene and p["level"] == "functional"),
                    key=lambda p: p["resolution"])
        cy = sorted((p for p in points if p["scene"] == scene and p["level"] == "cycle"),
                    key=lambda p: p["resolution"])
        xs = [p["resolution"] for p in fn]
        floor = 0.01
        if fn:
            axes[0].plot(xs, [max(floor, p["dram_bytes_per_ray"][0]) for p in fn], "--o", color=colour,
                         label="%s, frame 1 (cold)" % scene)
            axes[0].plot(xs, [max(floor, p["dram_bytes_per_ray"][-1]) for p in fn], "-s", color=colour,
                         label="%s, frame %d (steady)" % (scene, len(fn[0]["dram_bytes_per_ray"])))
        if cy:
            xc = [p["resolution"] for p in cy]
            axes[1].plot(xc, [p["cycles_per_ray"][0] for p in cy], "--o", color=colour,
                         label="%s, frame 1 (cold)" % scene)
            axes[1].plot(xc, [p["cycles_per_ray"][-1] for p in cy], "-s", color=colour,
                         label="%s, steady" % scene)
    axes[0].set_xscale("log", base=2)
    axes[0].set_yscale("log")
    axes[0].set_xlabel("resolution (square, pixels per side)")
    axes[0].set_ylabel("DRAM bytes read per ray (log; %.2g = none)" % 0.01)
    axes[0].set_title("DRAM traffic per ray (functional level)", fontsize=10)
    axes[1].set_xscale("log", base=2)
    axes[1].set_xlabel("resolution (square, pixels per side)")
    axes[1].set_ylabel("simulated cycles per ray")
    axes[1].set_title("Cycles per ray (cycle level)", fontsize=10)
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle("Memory traffic against resolution and frames, hardware '%s'" % data["hardware"], fontsize=10)
    fig.tight_layout()
    save(fig, os.path.join(out_dir, "accuracy_traffic.png"))


def ao_images(out_dir, data):
    """The AO images behind the RMSE numbers, side by side (white = open)."""
    import numpy as np
    n = data["ao_image_resolution"]
    pts = data.get("ao_rays_per_pixel", [])
    images = []
    for p in pts:
        name = "ao_reference.f32" if p["reference"] else "ao_%d.f32" % p["samples"]
        path = os.path.join(out_dir, "data", name)
        if os.path.exists(path):
            images.append((p, np.fromfile(path, dtype=np.float32).reshape(n, n)))
    if not images:
        return
    fig, axes = plt.subplots(1, len(images), figsize=(2.6 * len(images), 3.0), squeeze=False)
    for ax, (p, image) in zip(axes[0], images):
        ax.imshow(image, cmap="gray", vmin=0, vmax=1)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title("%d AO rays%s" % (p["samples"], " (reference)" if p["reference"] else
                                        "\nRMSE %.3g" % p["image_rmse"]), fontsize=9)
    fig.suptitle("AO images on %s, %dx%d" % (data["scene"], n, n), fontsize=10)
    save(fig, os.path.join(out_dir, "accuracy_ao_images.png"))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
