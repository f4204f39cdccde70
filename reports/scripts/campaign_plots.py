#!/usr/bin/env python3
"""Figures of a campaign report (rtsim report DB).

Usage: campaign_plots.py DATA.json OUTDIR

DATA.json is written by `rtsim report`: {"title": ..., "runs": [{label, builder, preset,
fidelity, scene, overrides, hardware, headline: {...}, stats: {dotted path: value}}]}.
Writes OUTDIR/<name>.png for every figure and OUTDIR/figures.json, a list of
{file, title, caption} in the order the report shows them. Needs Debian's
python3-matplotlib; every figure has labelled axes with units and a caption.
"""
import json
import math
import sys
from collections import OrderedDict, defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.patches  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

RAY_TYPES = ["primary", "ao", "shadow", "reflection", "refraction"]
KINDS = ["node", "triangle", "other"]
# Colour by data kind (what the architect trades), lightness by ray type.
KIND_COLOURS = {"node": "#1f77b4", "triangle": "#ff7f0e", "other": "#7f7f7f"}
PRESET_COLOURS = ["#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860"]
HATCHES = ["", "//", "xx", "..", "\\\\"]


def lighten(hex_colour, amount):
    r, g, b = (int(hex_colour[i:i + 2], 16) for i in (1, 3, 5))
    mix = lambda c: int(c + (255 - c) * amount)  # noqa: E731
    return "#%02x%02x%02x" % (mix(r), mix(g), mix(b))


def finite(v):
    return v is not None and isinstance(v, (int, float)) and math.isfinite(v)


def main():
    data_path, out_dir = sys.argv[1], sys.argv[2]
    with open(data_path) as f:
        data = json.load(f)
    runs = [r for r in data["runs"] if r["status"] == "ok"]
    figures = []

    def save(fig, name, title, caption):
        fig.tight_layout()
        # "tight" keeps legends placed outside the axes inside the picture.
        fig.savefig("%s/%s.png" % (out_dir, name), dpi=110, bbox_inches="tight")
        plt.close(fig)
        figures.append({"file": name + ".png", "title": title, "caption": caption})

    # The main comparison: runs without hardware overrides, one (scene, fidelity) slice
    # (the largest), builders x presets.
    plain = [r for r in runs if not r["overrides"]]
    slices = defaultdict(list)
    for r in plain:
        slices[(r["scene"], r["fidelity"])].append(r)
    if slices:
        (scene, fidelity), base = max(slices.items(), key=lambda kv: len(kv[1]))
        base_figures(base, scene, fidelity, save)
    sweep_figures(runs, save)
    scaling_figure(runs, save)
    energy_figure(plain, save)

    with open("%s/figures.json" % out_dir, "w") as f:
        json.dump(figures, f, indent=1)


def mean(values):
    values = [v for v in values if finite(v)]
    return sum(values) / len(values) if values else float("nan")


def base_figures(base, scene, fidelity, save):
    presets = sorted({r["preset"] for r in base})
    by = {(r["builder"], r["preset"]): r for r in base}
    # Builders sorted by mean DRAM bytes/ray over presets: the ranking is the message.
    builders = sorted({r["builder"] for r in base},
                      key=lambda b: mean(by[(b, p)]["headline"]["dram_bytes_per_ray"]
                                         for p in presets if (b, p) in by))
    where = "scene %s, fidelity %s" % (scene, fidelity)
    width = 0.8 / max(1, len(presets))
    xs = range(len(builders))

    # 1. DRAM bytes per ray, stacked by (ray type, data kind), one bar per preset.
    segments = []
    for t in RAY_TYPES:
        for k in KINDS:
            key = "dram.bytes_by_type.%s.%s" % (t, k)
            if any(finite(r["stats"].get(key)) and r["stats"].get(key) > 0 for r in base):
                segments.append((t, k, key))
    fig, ax = plt.subplots(figsize=(max(7, 1.3 * len(builders) * max(1, len(presets)) / 1.5), 4.8))
    for pi, preset in enumerate(presets):
        bottoms = [0.0] * len(builders)
        for si, (t, k, key) in enumerate(segments):
            heights = []
            for b in builders:
                r = by.get((b, preset))
                rays = r["headline"]["rays"] if r else None
                v = r["stats"].get(key) if r else None
                heights.append(v / rays if finite(v) and finite(rays) and rays > 0 else 0.0)
            ti = RAY_TYPES.index(t)
            ax.bar([x + (pi - (len(presets) - 1) / 2) * width for x in xs], heights, width * 0.95,
                   bottom=bottoms, color=lighten(KIND_COLOURS[k], 0.45 * ti / 2),
                   hatch=HATCHES[pi % len(HATCHES)], edgecolor="white" if pi == 0 else "black",
                   linewidth=0.4,
                   label="%s rays, %s data" % (t, k) if pi == 0 else None)
            bottoms = [a + h for a, h in zip(bottoms, heights)]
        for x, total in zip(xs, bottoms):
            ax.text(x + (pi - (len(presets) - 1) / 2) * width, total, "%.1f" % total,
                    ha="center", va="bottom", fontsize=7)
    ax.set_xticks(list(xs))
    ax.set_xticklabels(builders)
    ax.set_xlabel("BVH builder (sorted by mean DRAM bytes/ray)")
    ax.set_ylabel("DRAM bytes per ray [bytes/ray]")
    preset_note = ", ".join("%s%s" % (p, "" if i == 0 else " (hatched %s)" % HATCHES[i % len(HATCHES)])
                            for i, p in enumerate(presets))
    ax.set_title("DRAM traffic per ray by builder and preset")
    handles, labels = ax.get_legend_handles_labels()
    for pi, preset in enumerate(presets):  # which bar of a pair is which preset
        handles.append(matplotlib.patches.Patch(facecolor="white", edgecolor="black",
                                                hatch=HATCHES[pi % len(HATCHES)]))
        labels.append("preset %s" % preset)
    ax.legend(handles, labels, fontsize=7, ncol=1, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(axis="y", alpha=0.3)
    save(fig, "dram_bytes_per_ray", "DRAM bytes per ray",
         "DRAM bytes read per traced ray (all ray types), stacked by ray type and data kind "
         "(node, triangle, other = prim refs and stack spills); side-by-side bars are the "
         "hardware presets: %s. Lower is better. %s." % (preset_note, where))

    # 2. Hit rates: L1 node, L1 triangle, L2, one panel each, bars per preset.
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True)
    for ax, (metric, name) in zip(axes, [("l1_node_hit_rate", "L1 node cache"),
                                         ("l1_triangle_hit_rate", "L1 triangle cache"),
                                         ("l2_hit_rate", "shared L2")]):
        for pi, preset in enumerate(presets):
            vals = [by[(b, preset)]["headline"][metric] if (b, preset) in by else float("nan")
                    for b in builders]
            ax.bar([x + (pi - (len(presets) - 1) / 2) * width for x in xs],
                   [100 * v if finite(v) else 0 for v in vals], width * 0.95,
                   color=PRESET_COLOURS[pi % len(PRESET_COLOURS)], label=preset)
        ax.set_xticks(list(xs))
        ax.set_xticklabels(builders, rotation=40, ha="right")
        ax.set_title(name)
        ax.set_xlabel("BVH builder")
        ax.grid(axis="y", alpha=0.3)
        ax.set_ylim(0, 100)
    axes[0].set_ylabel("hit rate [%]")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, title="preset", fontsize=8, loc="upper left",
               bbox_to_anchor=(1.0, 0.95))
    save(fig, "hit_rates", "Cache hit rates",
         "Hit rate of the L1 node caches (all TRV units), the L1 triangle caches (all IST "
         "units) and the shared L2, per builder (same order as the DRAM figure) and preset. "
         "Higher is better. %s." % where)

    # 3. Simulated cycles.
    fig, ax = plt.subplots(figsize=(8, 4.2))
    for pi, preset in enumerate(presets):
        vals = [by[(b, preset)]["headline"]["cycles"] if (b, preset) in by else 0 for b in builders]
        ax.bar([x + (pi - (len(presets) - 1) / 2) * width for x in xs],
               [v / 1e3 if finite(v) else 0 for v in vals], width * 0.95,
               color=PRESET_COLOURS[pi % len(PRESET_COLOURS)], label=preset)
    ax.set_xticks(list(xs))
    ax.set_xticklabels(builders)
    ax.set_xlabel("BVH builder")
    ax.set_ylabel("simulated cycles [thousands of accelerator cycles]")
    ax.set_title("Simulated time for the whole frame")
    ax.legend(title="preset")
    ax.grid(axis="y", alpha=0.3)
    save(fig, "cycles", "Simulated cycles",
         "Accelerator cycles to trace every ray of the frame (at the preset's clock; the "
         "fidelity level decides how time is modelled). Lower is better. %s." % where)

    # 4. Ops per ray, TRV + IST, and node fetches per ray by ray type: properties of the
    # tree and the rays, identical across presets (the first preset is shown).
    preset = presets[0]
    types = [t for t in RAY_TYPES
             if any(finite(r["stats"].get("per_type.%s.rays" % t)) for r in base)]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.4))
    tw = 0.8 / max(1, len(types))
    for ti, t in enumerate(types):
        trv, ist = [], []
        for b in builders:
            r = by.get((b, preset))
            s = r["stats"] if r else {}
            rays = s.get("per_type.%s.rays" % t)
            ok = finite(rays) and rays > 0
            trv.append(s.get("per_type.%s.trv_ops" % t, 0) / rays if ok else 0)
            ist.append(s.get("per_type.%s.ist_ops" % t, 0) / rays if ok else 0)
        pos = [x + (ti - (len(types) - 1) / 2) * tw for x in xs]
        colour = PRESET_COLOURS[ti % len(PRESET_COLOURS)]
        ax1.bar(pos, trv, tw * 0.95, color=colour, label="%s rays: TRV ops" % t)
        ax1.bar(pos, ist, tw * 0.95, bottom=trv, color=lighten(colour, 0.55),
                label="%s rays: IST ops" % t)
        fetches = []
        for b in builders:
            r = by.get((b, preset))
            s = r["stats"] if r else {}
            rays = s.get("per_type.%s.rays" % t)
            f = s.get("per_type.%s.node_fetches" % t)
            fetches.append(f / rays if finite(f) and finite(rays) and rays > 0 else 0)
        ax2.bar(pos, fetches, tw * 0.95, color=colour, label="%s rays" % t)
    for ax in (ax1, ax2):
        ax.set_xticks(list(xs))
        ax.set_xticklabels(builders, rotation=30, ha="right")
        ax.set_xlabel("BVH builder")
        ax.grid(axis="y", alpha=0.3)
    ax1.set_ylabel("operations per ray [ops/ray]")
    ax1.set_title("Ops per ray (TRV + IST) by ray type")
    if types:  # runs that report per-ray-type counts
        ax1.legend(fontsize=7)
    ax2.set_ylabel("node fetches per ray [fetches/ray]")
    ax2.set_title("Node fetches per ray by ray type")
    if types:
        ax2.legend(fontsize=7)
    save(fig, "ops_and_fetches", "Ops and node fetches per ray",
         "Left: TRV ops (one ray x one node) and IST ops (one ray-triangle test) per ray, "
         "stacked, by ray type; right: BVH node fetches issued by TRV per ray (before the "
         "caches). These depend on the tree and the rays only, not on the hardware preset "
         "(shown: %s). Lower is better. %s." % (preset, where))


def binary_size(n):
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size and n % size == 0:
            return "%d %s" % (n // size, unit)
    return "%d B" % n


def hardware_value(hardware, dotted):
    node = hardware
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node if finite(node) else None


def sweep_figures(runs, save):
    keys = sorted({k for r in runs for k in r["overrides"]})
    for key in keys:
        series = OrderedDict()
        for r in runs:
            if not set(r["overrides"]) <= {key}:
                continue
            x = hardware_value(r["hardware"], key)
            if x is None:
                continue
            s = series.setdefault((r["builder"], r["preset"], r["scene"], r["fidelity"]), {})
            s[x] = r
        series = OrderedDict((k, v) for k, v in series.items() if len(v) >= 2)
        if not series:
            continue
        xs_all = sorted({x for s in series.values() for x in s})
        log2 = all(x > 0 and (int(x) & (int(x) - 1)) == 0 and x == int(x) for x in xs_all)
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.4))
        for i, ((builder, preset, scene, fidelity), points) in enumerate(series.items()):
            xs = sorted(points)
            colour = PRESET_COLOURS[i % len(PRESET_COLOURS)]
            label = "%s / %s" % (builder, preset)
            ax1.plot(xs, [points[x]["headline"]["dram_bytes_per_ray"] for x in xs], "o-",
                     color=colour, label=label)
            ax2.plot(xs, [100 * points[x]["headline"]["l2_hit_rate"]
                          if finite(points[x]["headline"]["l2_hit_rate"]) else float("nan")
                          for x in xs], "o-", color=colour, label=label)
        unit = "bytes" if key.endswith("bytes") else ""
        for ax in (ax1, ax2):
            ax.minorticks_off()
            if log2:
                ax.set_xscale("log", base=2)
                ax.set_xticks(xs_all)
                if unit == "bytes":
                    ax.set_xticklabels([binary_size(x) for x in xs_all])
                else:
                    ax.set_xticklabels(["%g" % x for x in xs_all])
            ax.set_xlabel("%s%s" % (key, " [%s]" % unit if unit else ""))
            ax.grid(alpha=0.3)
            ax.legend(title="builder / preset", fontsize=8)
        ax1.set_ylabel("DRAM bytes per ray [bytes/ray]")
        ax1.set_title("DRAM traffic vs %s" % key)
        ax1.set_ylim(bottom=0)
        ax2.set_ylabel("L2 hit rate [%]")
        ax2.set_title("L2 hit rate vs %s" % key)
        name = "sweep_" + key.replace(".", "_")
        save(fig, name, "Sweep of %s" % key,
             "DRAM bytes per ray (left, lower is better) and L2 hit rate (right, higher is "
             "better) as %s varies, one line per builder and preset; every other parameter "
             "at its preset value." % key)


def scaling_figure(runs, save):
    """Rays per cycle against a `cores` sweep, with the two bounds no run passes."""
    series = OrderedDict()
    for r in runs:
        if set(r["overrides"]) != {"cores"}:
            continue
        cores = hardware_value(r["hardware"], "cores")
        st = r["stats"]
        need = ["rays.total", "time.cycles", "dram.bytes", "machine.trv_passes",
                "machine.peak_trv_passes_per_cycle", "machine.peak_dram_bytes_per_cycle"]
        if cores is None or not all(finite(st.get(k)) for k in need) or st["time.cycles"] <= 0:
            continue
        rays = st["rays.total"]
        dram_per_ray = (st["dram.bytes"] + st.get("dram.bytes_written", 0)) / rays
        point = {
            "rays_per_cycle": rays / st["time.cycles"],
            "dram_bound": st["machine.peak_dram_bytes_per_cycle"] / dram_per_ray if dram_per_ray > 0 else float("nan"),
            "trv_bound": st["machine.peak_trv_passes_per_cycle"] / (st["machine.trv_passes"] / rays),
        }
        series.setdefault((r["scene"], r["builder"], r["preset"], r["fidelity"]), {})[cores] = point
    series = OrderedDict((k, v) for k, v in series.items() if len(v) >= 2)
    if not series:
        return
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.6))
    xs_all = sorted({x for s in series.values() for x in s})
    for i, ((scene, builder, preset, fidelity), points) in enumerate(series.items()):
        xs = sorted(points)
        colour = PRESET_COLOURS[i % len(PRESET_COLOURS)]
        label = "%s / %s" % (scene, builder)
        ax1.plot(xs, [points[x]["rays_per_cycle"] for x in xs], "o-", color=colour, label=label + ": measured")
        ax1.plot(xs, [points[x]["dram_bound"] for x in xs], "--", color=colour, label=label + ": DRAM bound")
        ax1.plot(xs, [points[x]["trv_bound"] for x in xs], ":", color=colour, label=label + ": TRV bound")
        ax2.plot(xs, [100 * points[x]["rays_per_cycle"] / min(points[x]["dram_bound"], points[x]["trv_bound"])
                      for x in xs], "o-", color=colour, label=label)
    for ax in (ax1, ax2):
        ax.set_xscale("log", base=2)
        ax.minorticks_off()
        ax.set_xticks(xs_all)
        ax.set_xticklabels(["%g" % x for x in xs_all])
        ax.set_xlabel("RT cores")
        ax.grid(alpha=0.3)
    ax1.set_yscale("log")
    ax1.set_ylabel("rays per cycle [rays/cycle]")
    ax1.set_title("Throughput against cores")
    ax1.legend(fontsize=7)
    ax2.set_ylim(0, 105)
    ax2.set_ylabel("rays per cycle / the lower bound [%]")
    ax2.set_title("How close to the binding bound")
    ax2.legend(fontsize=8)
    preset = next(iter(series))[2]
    save(fig, "scaling_cores", "Scaling with RT cores",
         "Left: rays per cycle (solid) against the number of RT cores on the %s machine, with "
         "the DRAM bound (dashed: peak DRAM bytes per cycle / DRAM bytes read and written per ray "
         "at that core count) and the TRV bound (dotted: the cores' box-test passes per cycle / "
         "passes per ray); no run can lie above either. Right: the measured rate as a share of the "
         "lower bound: where it stays flat the cores keep up with what memory allows." % preset)


def energy_figure(plain, save):
    """Energy per ray by component, per builder (cycle or lt runs that report it)."""
    parts = ["trv", "ist", "l1_node", "l1_triangle", "l2", "noc", "dram"]
    colours = ["#4c72b0", "#dd8452", "#55a868", "#8172b3", "#c44e52", "#937860", "#7f7f7f"]
    slices = defaultdict(list)
    for r in plain:
        if finite(r["stats"].get("energy.pj_per_ray")) and r["fidelity"] != "functional":
            slices[(r["scene"], r["preset"])].append(r)
    if not slices:
        return
    keys = sorted(slices)
    fig, axes = plt.subplots(1, len(keys), figsize=(4.2 * len(keys) + 1, 4.4), squeeze=False)
    for ax, key in zip(axes[0], keys):
        # One run per builder: the cycle level's where there is one.
        chosen = {}
        for r in slices[key]:
            if r["builder"] not in chosen or r["fidelity"] == "cycle":
                chosen[r["builder"]] = r
        by_builder = OrderedDict(
            (b, r) for b, r in sorted(chosen.items(), key=lambda kv: kv[1]["stats"]["energy.pj_per_ray"]))
        names = list(by_builder)
        bottom = [0.0] * len(names)
        for part, colour in zip(parts, colours):
            values = [by_builder[n]["stats"].get("energy.%s.pj_per_ray" % part, 0) / 1000 for n in names]
            ax.bar(range(len(names)), values, bottom=bottom, color=colour, label=part)
            bottom = [b + v for b, v in zip(bottom, values)]
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels(names, rotation=45, ha="right", fontsize=8)
        ax.set_ylabel("energy per ray [nJ/ray]")
        ax.set_title("%s / %s" % key)
        ax.grid(axis="y", alpha=0.3)
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    save(fig, "energy_per_ray", "Energy per ray by component",
         "Dynamic energy per ray (nJ) split by component (cycle-level runs where there are), builders "
         "sorted by total; per-access "
         "energies and their sources are the energy.* and dram.*_pj parameters (docs/machine.md). "
         "Leakage and DRAM background power are not modelled.")


if __name__ == "__main__":
    main()
