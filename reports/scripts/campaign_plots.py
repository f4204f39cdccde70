#!/usr/bin/env python3
"""Figures of a campaign report (rtsim report DB).

Usage: campaign_plots.py DATA.json OUTDIR

DATA.json is written by `rtsim report`: {"title", "names": the model's vocabulary
(byte kinds, ray types, cycle buckets, energy components, stat names), "coordinates":
the swept axes [{key, unit, values}], "runs": [{job_key, label, builder, preset,
fidelity, scene, coordinates: {axis: value}, plain, hardware, headline, stats}]}.
The names come from the model, never from here: a figure stacks exactly the kinds the
model writes.

Writes OUTDIR/<name>.png for every figure, OUTDIR/<name>.data.json with what it drew
(plot_files.save: every bar, segment and point with the run and the stat it shows, so a
test can hold the figure to the stats), and OUTDIR/figures.json, a list of {file,
title, caption} in the order the report shows them. Needs Debian's python3-matplotlib;
every figure has labelled axes with units and a caption.
"""
import json
import math
import os
import sys
from collections import OrderedDict, defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import plot_files  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.patches  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

# Colour by data kind (what the architect trades), lightness by ray type.
KIND_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#7f7f7f", "#9467bd", "#8c564b"]
PRESET_COLOURS = ["#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860"]
BUCKET_COLOURS = {"busy": "#2ca02c", "waiting_l1": "#aec7e8", "waiting_noc": "#ffbb78",
                  "waiting_l2": "#1f77b4", "waiting_dram": "#d62728", "blocked": "#9467bd",
                  "waiting_ist": "#e377c2", "latency": "#bcbd22", "idle": "#dddddd"}
HATCHES = ["", "//", "xx", "..", "\\\\"]


def lighten(hex_colour, amount):
    r, g, b = (int(hex_colour[i:i + 2], 16) for i in (1, 3, 5))
    mix = lambda c: int(c + (255 - c) * amount)  # noqa: E731
    return "#%02x%02x%02x" % (mix(r), mix(g), mix(b))


def type_lightness(ray_type, ray_types):
    """How much lighter a ray type's segment is, by its place among the types drawn:
    0 for the first, 0.15 apart up to five, and the range 0..0.6 shared beyond."""
    return 0.6 * ray_types.index(ray_type) / max(4, len(ray_types) - 1)


def finite(v):
    return v is not None and isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def mean(values):
    values = [v for v in values if finite(v)]
    return sum(values) / len(values) if values else float("nan")


class Figures:
    """Saves figures with what they drew, and lists them for the report."""

    def __init__(self, out_dir):
        self.out_dir = out_dir
        self.listed = []

    def save(self, fig, name, title, caption, drawn):
        fig.tight_layout()
        plot_files.save(fig, os.path.join(self.out_dir, name + ".png"),
                        data={"figure": name, "title": title, "drawn": drawn})
        self.listed.append({"file": name + ".png", "title": title, "caption": caption})


def drawn_value(run, value, stat, scale=1.0, parts=None, **where):
    """One bar, segment sum or point: `value` is `scale` x the run's `stat` (a stat
    name, or "a / b" of two); `parts` the stacked segments that add up to it."""
    entry = {"job_key": run["job_key"], "value": value, "stat": stat, "scale": scale}
    if parts is not None:
        entry["parts"] = parts
    entry.update(where)
    return entry


def stat_value(run, stat):
    s = run["stats"]
    if " / " in stat:
        a, b = stat.split(" / ")
        return s[a] / s[b] if finite(s.get(a)) and finite(s.get(b)) and s[b] else float("nan")
    return s.get(stat, float("nan"))


def main():
    data_path, out_dir = sys.argv[1], sys.argv[2]
    with open(data_path) as f:
        data = json.load(f)
    names = data["names"]
    runs = [r for r in data["runs"] if r["status"] == "ok"]
    figures = Figures(out_dir)

    # The main comparison: the plain runs (every swept axis at its default) of the
    # largest (scene, fidelity) slice, builders x presets.
    slices = defaultdict(list)
    for r in runs:
        if r["plain"]:
            slices[(r["scene"], r["fidelity"])].append(r)
    if slices:
        (scene, fidelity), base = max(slices.items(), key=lambda kv: len(kv[1]))
        base_figures(base, scene, fidelity, names, figures)
    for axis in data["coordinates"]:
        sweep_figure(runs, axis, data["coordinates"], names, figures)
    scaling_figure(runs, figures)

    plot_files.write_json(os.path.join(out_dir, "figures.json"), figures.listed)


def group_layout(base):
    """Where each plain run's bar goes: x groups (builders, or presets when there is one
    builder) and, within a group, one bar per preset."""
    presets = sorted({r["preset"] for r in base})
    by = {(r["builder"], r["preset"]): r for r in base}
    # Builders sorted by mean DRAM bytes/ray over presets: the ranking is the message.
    builders = sorted({r["builder"] for r in base},
                      key=lambda b: mean(by[(b, p)]["headline"]["dram_bytes_per_ray"]
                                         for p in presets if (b, p) in by))
    if len(builders) == 1:  # one builder: the presets are the groups, one bar each
        groups = [(p, [(p, by.get((builders[0], p)))]) for p in presets]
        return groups, [None], "hardware preset (builder %s)" % builders[0]
    groups = [(b, [(p, by.get((b, p))) for p in presets]) for b in builders]
    return groups, presets, "BVH builder (sorted by mean DRAM bytes/ray)"


def bar_positions(groups):
    width = 0.8 / max(1, max(len(bars) for _, bars in groups))
    out = []
    for gi, (_, bars) in enumerate(groups):
        for bi, (preset, run) in enumerate(bars):
            out.append((gi + (bi - (len(bars) - 1) / 2) * width, width, bi, preset, run))
    return out


def preset_legend(ax, presets, handles=None, labels=None):
    handles = handles or []
    labels = labels or []
    if presets != [None] and len(presets) > 1:
        for pi, preset in enumerate(presets):  # which bar of a group is which preset
            handles.append(matplotlib.patches.Patch(facecolor="white", edgecolor="black",
                                                    hatch=HATCHES[pi % len(HATCHES)]))
            labels.append("preset %s" % preset)
    return handles, labels


def base_figures(base, scene, fidelity, names, figures):
    groups, presets, x_label = group_layout(base)
    positions = bar_positions(groups)
    where = "scene %s, fidelity %s" % (scene, fidelity)
    xs = range(len(groups))
    group_names = [g for g, _ in groups]
    ray_types, kinds = names["ray_types"], names["byte_kinds"]
    by_type = names["stats"]["dram_bytes_by_type"]

    # 1. DRAM bytes per ray, stacked by (ray type, byte kind): the kinds the model writes.
    segments = [(t, k) for t in ray_types for k in kinds
                if any(finite(r["stats"].get("%s.%s.%s" % (by_type, t, k))) for r in base)]
    drawn_types = [t for t in ray_types if any(t == s for s, _ in segments)]
    fig, ax = plt.subplots(figsize=(max(7, 0.9 * len(positions) + 3), 4.8))
    drawn = []
    labelled = set()
    for x, width, bi, preset, r in positions:
        if r is None:
            continue
        rays = r["stats"].get(names["stats"]["rays"])
        bottom, parts = 0.0, OrderedDict()
        for t, k in segments:
            v = r["stats"].get("%s.%s.%s" % (by_type, t, k))
            h = v / rays if finite(v) and finite(rays) and rays > 0 else 0.0
            label = "%s rays, %s data" % (t, k)
            ax.bar(x, h, width * 0.95, bottom=bottom,
                   color=lighten(KIND_COLOURS[kinds.index(k) % len(KIND_COLOURS)], type_lightness(t, drawn_types)),
                   hatch=HATCHES[bi % len(HATCHES)], edgecolor="white" if bi == 0 else "black", linewidth=0.4,
                   label=label if label not in labelled else None)
            labelled.add(label)
            parts[label] = h
            bottom += h
        ax.text(x, bottom, "%.1f" % bottom, ha="center", va="bottom", fontsize=7)
        drawn.append(drawn_value(r, bottom, names["stats"]["dram_bytes_per_ray"], parts=parts,
                                 group=r["builder"], preset=r["preset"]))
    ax.set_xticks(list(xs))
    ax.set_xticklabels(group_names)
    ax.set_xlabel(x_label)
    ax.set_ylabel("DRAM bytes per ray [bytes/ray]")
    ax.set_title("DRAM traffic per ray" + (" by builder and preset" if presets != [None] else " by preset"))
    handles, labels = preset_legend(ax, presets, *ax.get_legend_handles_labels())
    ax.legend(handles, labels, fontsize=7, ncol=1, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(axis="y", alpha=0.3)
    preset_note = (" Side-by-side bars are the presets: %s." % ", ".join(
        "%s%s" % (p, "" if i == 0 else " (hatched %s)" % HATCHES[i % len(HATCHES)]) for i, p in enumerate(presets))
                   if presets != [None] and len(presets) > 1 else "")
    figures.save(fig, "dram_bytes_per_ray", "DRAM bytes per ray",
                 "DRAM bytes read per traced ray (all ray types), stacked by ray type and the model's byte "
                 "kinds (%s); the bar's total is dram.bytes_per_ray.%s Lower is better. %s."
                 % (", ".join(kinds), preset_note, where), drawn)

    # 2. Hit rates: L1 node, L1 triangle, L2, one panel each.
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True)
    drawn = []
    levels = [("l1_node_hit_rate", "l1_node.all.hit_rate", "L1 node cache"),
              ("l1_triangle_hit_rate", "l1_triangle.all.hit_rate", "L1 triangle cache"),
              ("l2_hit_rate", "l2.hit_rate", "shared L2")]
    for ax, (metric, stat, title) in zip(axes, levels):
        labelled = set()
        for x, width, bi, preset, r in positions:
            if r is None:
                continue
            v = r["headline"][metric]
            ax.bar(x, 100 * v if finite(v) else 0, width * 0.95, color=PRESET_COLOURS[bi % len(PRESET_COLOURS)],
                   label=preset if preset and preset not in labelled else None)
            labelled.add(preset)
            if finite(v):
                drawn.append(drawn_value(r, 100 * v, stat, 100.0, panel=title))
        ax.set_xticks(list(xs))
        ax.set_xticklabels(group_names, rotation=40, ha="right")
        ax.set_title(title)
        ax.set_xlabel(x_label.split(" (")[0])
        ax.grid(axis="y", alpha=0.3)
        ax.set_ylim(0, 100)
    axes[0].set_ylabel("hit rate [%]")
    if presets != [None] and len(presets) > 1:
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, title="preset", fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 0.95))
    figures.save(fig, "hit_rates", "Cache hit rates",
                 "Hit rate of the L1 node caches (all TRV units), the L1 triangle caches (all IST units) and the "
                 "shared L2, in the same order as the DRAM figure. Higher is better. %s." % where, drawn)

    # 3. Simulated cycles.
    fig, ax = plt.subplots(figsize=(8, 4.2))
    drawn = []
    labelled = set()
    for x, width, bi, preset, r in positions:
        if r is None:
            continue
        v = r["stats"].get(names["stats"]["cycles"])
        ax.bar(x, v / 1e3 if finite(v) else 0, width * 0.95, color=PRESET_COLOURS[bi % len(PRESET_COLOURS)],
               label=preset if preset and preset not in labelled else None)
        labelled.add(preset)
        if finite(v):
            drawn.append(drawn_value(r, v / 1e3, names["stats"]["cycles"], 1e-3))
    ax.set_xticks(list(xs))
    ax.set_xticklabels(group_names)
    ax.set_xlabel(x_label)
    ax.set_ylabel("simulated cycles [thousands of accelerator cycles]")
    ax.set_title("Simulated time for the whole frame")
    if presets != [None] and len(presets) > 1:
        ax.legend(title="preset")
    ax.grid(axis="y", alpha=0.3)
    figures.save(fig, "cycles", "Simulated cycles",
                 "Accelerator cycles to trace every ray of the frame (at the preset's clock; %s). Lower is "
                 "better. %s." % ("an analytic estimate at the functional level" if fidelity == "functional"
                                  else "the %s level's time" % fidelity, where), drawn)

    # 4. Where the cycles went: each unit kind's exclusive split, the mean over its units.
    if fidelity != "functional":
        accounting_figure(positions, group_names, x_label, presets, names, where, figures)

    # 5. Ops per ray, TRV + IST, and node fetches per ray by ray type: properties of the
    # tree and the rays, identical across presets (the first preset's runs are shown).
    first = [(x, run) for x, width, bi, preset, run in positions if bi == 0 and run is not None]
    types = [t for t in ray_types if any(finite(r["stats"].get("per_type.%s.rays" % t)) for _, r in first)]
    if types:
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.4))
        tw = 0.8 / len(types)
        drawn = []
        for ti, t in enumerate(types):
            colour = PRESET_COLOURS[ti % len(PRESET_COLOURS)]
            for gi, (x, r) in enumerate(first):
                s = r["stats"]
                rays = s.get("per_type.%s.rays" % t)
                if not (finite(rays) and rays > 0):
                    continue
                pos = gi + (ti - (len(types) - 1) / 2) * tw
                trv, ist = s.get("per_type.%s.trv_ops" % t, 0) / rays, s.get("per_type.%s.ist_ops" % t, 0) / rays
                ax1.bar(pos, trv, tw * 0.95, color=colour, label="%s rays: TRV ops" % t if gi == 0 else None)
                ax1.bar(pos, ist, tw * 0.95, bottom=trv, color=lighten(colour, 0.55),
                        label="%s rays: IST ops" % t if gi == 0 else None)
                drawn.append(drawn_value(r, trv + ist, "per_type.%s.ops_per_ray" % t,
                                         parts={"TRV ops": trv, "IST ops": ist}, panel="ops", ray_type=t))
                f = s.get("per_type.%s.node_fetches" % t, 0) / rays
                ax2.bar(pos, f, tw * 0.95, color=colour, label="%s rays" % t if gi == 0 else None)
                drawn.append(drawn_value(r, f, "per_type.%s.node_fetches / per_type.%s.rays" % (t, t),
                                         panel="node fetches", ray_type=t))
        for ax in (ax1, ax2):
            ax.set_xticks(range(len(first)))
            ax.set_xticklabels([r["builder"] if presets != [None] else r["preset"] for _, r in first],
                               rotation=30, ha="right")
            ax.set_xlabel(x_label.split(" (")[0])
            ax.grid(axis="y", alpha=0.3)
            ax.legend(fontsize=7)
        ax1.set_ylabel("operations per ray [ops/ray]")
        ax1.set_title("Ops per ray (TRV + IST) by ray type")
        ax2.set_ylabel("node fetches per ray [fetches/ray]")
        ax2.set_title("Node fetches per ray by ray type")
        figures.save(fig, "ops_and_fetches", "Ops and node fetches per ray",
                     "Left: TRV ops (one ray x one node) and IST ops (one ray-triangle test) per ray, stacked, by "
                     "ray type; right: BVH node fetches issued by TRV per ray (before the caches). These depend on "
                     "the tree and the rays only, not on the hardware%s. Lower is better. %s."
                     % (" (shown: preset %s)" % presets[0] if presets != [None] else "", where), drawn)

    # 6. Energy per ray by component (the timed levels: only they count DRAM commands).
    if fidelity != "functional":
        energy_figure(positions, group_names, x_label, presets, names, where, figures)


def accounting_figure(positions, group_names, x_label, presets, names, where, figures):
    units = [u for u in names["unit_kinds"]
             if any(finite(r["stats"].get("machine.%s.busy_cycles.mean" % u["name"])) for *_, r in positions if r)]
    if not units:
        return
    fig, axes = plt.subplots(1, len(units), figsize=(4.6 * len(units) + 2, 4.4), squeeze=False)
    drawn = []
    labelled = set()
    for ax, unit in zip(axes[0], units):
        for x, width, bi, preset, r in positions:
            if r is None:
                continue
            s = r["stats"]
            cycles = s.get(names["stats"]["cycles"])
            if not (finite(cycles) and cycles > 0):
                continue
            bottom, parts = 0.0, OrderedDict()
            for bucket in unit["buckets"]:
                v = s.get("machine.%s.%s_cycles.mean" % (unit["name"], bucket), 0.0)
                ax.bar(x, 100 * v / cycles, width * 0.95, bottom=bottom, color=BUCKET_COLOURS.get(bucket, "#999999"),
                       hatch=HATCHES[bi % len(HATCHES)], edgecolor="white" if bi == 0 else "black", linewidth=0.4,
                       label=bucket if bucket not in labelled else None)
                labelled.add(bucket)
                parts[bucket] = v
                bottom += 100 * v / cycles
            # The buckets are exclusive: a unit's add up to the run's cycles.
            drawn.append(drawn_value(r, sum(parts.values()), names["stats"]["cycles"], parts=parts, unit=unit["name"]))
        ax.set_xticks(range(len(group_names)))
        ax.set_xticklabels(group_names, rotation=30, ha="right")
        ax.set_ylim(0, 100)
        ax.set_ylabel("share of the simulated cycles [%]")
        ax.set_xlabel(x_label.split(" (")[0])
        ax.set_title("%s units" % unit["name"].upper())
        ax.grid(axis="y", alpha=0.3)
    handles, labels = preset_legend(axes[0][-1], presets, *axes[0][0].get_legend_handles_labels())
    axes[0][-1].legend(handles, labels, fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    meaning = "; ".join("%s: %s" % (b["name"], b["meaning"]) for b in names["cycle_buckets"])
    figures.save(fig, "cycle_accounting", "Where the cycles went",
                 "Each unit kind's cycles split exclusively (mean over its units, in %% of the run's cycles; the "
                 "parts add up to time.cycles): %s. %s." % (meaning, where), drawn)


def energy_figure(positions, group_names, x_label, presets, names, where, figures):
    parts_names = names["energy_components"]
    colours = ["#4c72b0", "#dd8452", "#55a868", "#8172b3", "#c44e52", "#937860", "#7f7f7f"]
    fig, ax = plt.subplots(figsize=(max(7, 0.9 * len(positions) + 3), 4.4))
    drawn = []
    labelled = set()
    for x, width, bi, preset, r in positions:
        if r is None or not finite(r["stats"].get(names["stats"]["energy_per_ray"])):
            continue
        bottom, parts = 0.0, OrderedDict()
        for part, colour in zip(parts_names, colours):
            v = r["stats"].get("energy.%s.pj_per_ray" % part, 0) / 1000
            ax.bar(x, v, width * 0.95, bottom=bottom, color=colour, hatch=HATCHES[bi % len(HATCHES)],
                   edgecolor="white" if bi == 0 else "black", linewidth=0.4,
                   label=part if part not in labelled else None)
            labelled.add(part)
            parts[part] = v
            bottom += v
        drawn.append(drawn_value(r, bottom, names["stats"]["energy_per_ray"], 1e-3, parts=parts))
    if not drawn:
        plt.close(fig)
        return
    ax.set_xticks(range(len(group_names)))
    ax.set_xticklabels(group_names, rotation=30, ha="right")
    ax.set_xlabel(x_label)
    ax.set_ylabel("energy per ray [nJ/ray]")
    ax.set_title("Energy per ray by component")
    ax.grid(axis="y", alpha=0.3)
    handles, labels = preset_legend(ax, presets, *ax.get_legend_handles_labels())
    ax.legend(handles, labels, fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    figures.save(fig, "energy_per_ray", "Energy per ray by component",
                 "Dynamic energy per ray (nJ) by component, stacked; the total is energy.pj_per_ray. Per-access "
                 "energies and their sources are the energy.* and dram.*_pj parameters (docs/machine.md); leakage "
                 "and DRAM background power are not modelled. %s." % where, drawn)


def binary_size(n):
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size and n % size == 0:
            return "%d %s" % (n // size, unit)
    return "%d B" % n


def axis_label(key, unit):
    return "%s [%s]" % (key, unit) if unit else key


# What a sweep figure shows against the swept value, one row of panels each.
SWEEP_METRICS = [
    ("cycles", "simulated cycles [thousands]", "time.cycles", 1e-3, True),
    ("DRAM bytes per ray", "DRAM bytes per ray [bytes/ray]", "dram.bytes_per_ray", 1.0, True),
    ("energy per ray", "energy per ray [nJ/ray]", "energy.pj_per_ray", 1e-3, False),  # timed levels only
    ("TRV utilisation", "TRV utilisation (mean over units) [%]", "machine.trv.utilisation.mean", 100.0, True),
]


def sweep_figure(runs, axis, all_axes, names, figures):
    """Every metric against one swept axis, numerically sorted, with its unit; a column
    of panels per builder. A line holds the runs that differ in this axis only."""
    key, unit = axis["key"], axis["unit"]
    if len(axis["values"]) < 2:
        return
    others = [a["key"] for a in all_axes if a["key"] != key]
    series = OrderedDict()
    for r in runs:
        x = r["coordinates"].get(key)
        if x is None:
            continue
        ident = (r["builder"], r["scene"], r["preset"], r["fidelity"]) + tuple(
            json.dumps(r["coordinates"].get(o)) for o in others)
        series.setdefault(ident, {})[json.dumps(x)] = (x, r)
    series = OrderedDict((k, v) for k, v in series.items() if len(v) >= 2)
    if not series:
        return
    numeric = all(finite(x) for s in series.values() for x, _ in s.values())
    xs_all = sorted({x for s in series.values() for x, _ in s.values()}, key=lambda v: (not finite(v), v))
    log2 = numeric and all(x > 0 and x == int(x) and (int(x) & (int(x) - 1)) == 0 for x in xs_all) and len(xs_all) > 2
    builders = sorted({ident[0] for ident in series})
    timed = any(ident[3] != "functional" for ident in series)
    metrics = [m for m in SWEEP_METRICS if m[4] or timed]
    fig, axes = plt.subplots(len(metrics), len(builders), figsize=(4.4 * len(builders) + 2.5, 2.7 * len(metrics)),
                             squeeze=False, sharex=True)
    drawn = []
    colour_of = {}
    # A line's label names what tells it from the others: the parts that vary.
    fields = [("scene", 1), ("preset", 2), ("level", 3)] + [(o, 4 + i) for i, o in enumerate(others)]
    varying = [(name, i) for name, i in fields if len({ident[i] for ident in series}) > 1]
    for ident, points in series.items():
        column = builders.index(ident[0])
        ordered = sorted(points.values(), key=lambda p: (not finite(p[0]), p[0]))
        label = " / ".join(str(ident[i]) if i < 4 else "%s=%s" % (name, json.loads(ident[i])) for name, i in varying)
        label = label or "%s / %s / %s" % (ident[1], ident[2], ident[3])
        colour = colour_of.setdefault(label, PRESET_COLOURS[len(colour_of) % len(PRESET_COLOURS)])
        for row, (name, y_label, stat, scale, untimed_ok) in enumerate(metrics):
            chosen = [(x, r) for x, r in ordered if untimed_ok or r["fidelity"] != "functional"]
            values = [scale * stat_value(r, stat) for _, r in chosen]
            ok = [(x, v, r) for (x, r), v in zip(chosen, values) if finite(v)]
            if not ok:
                continue
            positions = [x if numeric else xs_all.index(x) for x, _, _ in ok]
            axes[row][column].plot(positions, [v for _, v, _ in ok], "o-", color=colour,
                                   label=label if row == 0 else None)
            for (x, v, r) in ok:
                drawn.append(drawn_value(r, v, stat, scale, x=x, metric=name, builder=ident[0]))
    for column, builder in enumerate(builders):
        for row, (name, y_label, stat, scale, untimed_ok) in enumerate(metrics):
            ax = axes[row][column]
            ax.grid(alpha=0.3)
            ax.minorticks_off()
            if row == 0:
                ax.set_title("builder %s" % builder)
            if column == 0:
                ax.set_ylabel(y_label, fontsize=8)
            ax.set_ylim(bottom=0)
            if numeric:
                if log2:
                    ax.set_xscale("log", base=2)
                ax.set_xticks(xs_all)
                ax.set_xticklabels([binary_size(int(x)) if unit == "bytes" and x == int(x) else "%g" % x
                                    for x in xs_all], rotation=30, fontsize=7)
            else:
                ax.set_xticks(range(len(xs_all)))
                ax.set_xticklabels([str(x) for x in xs_all], rotation=30, fontsize=7)
            if row == len(metrics) - 1:
                ax.set_xlabel(axis_label(key, unit))
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                       title=" / ".join(name for name, _ in varying) or "scene / preset / level")
    name = "sweep_" + key.replace(".", "_")
    figures.save(fig, name, "Sweep of %s" % key,
                 "%s against %s%s, one line per scene, preset and level (and value of the other swept axes)%s; "
                 "the run with no override (or one equal to the preset's value; a workload axis at "
                 "simulate's default, else its smallest value) is the point at the default. "
                 "Energy is drawn for the lt and cycle levels only (the functional level counts no DRAM commands)."
                 % (", ".join(m[0] for m in metrics), axis_label(key, unit),
                    " (numerically sorted)" if numeric else "",
                    ", a column per builder" if len(builders) > 1 else ""), drawn)


def scaling_figure(runs, figures):
    """Rays per cycle against a `cores` sweep, with the two bounds no run passes."""
    series = OrderedDict()
    for r in runs:
        cores = r["coordinates"].get("cores")
        others = {k: v for k, v in r["coordinates"].items() if k != "cores"}
        st = r["stats"]
        need = ["rays.total", "time.cycles", "dram.bytes", "machine.trv_passes",
                "machine.peak_trv_passes_per_cycle", "machine.peak_dram_bytes_per_cycle"]
        if not finite(cores) or not all(finite(st.get(k)) for k in need) or st["time.cycles"] <= 0:
            continue
        rays = st["rays.total"]
        dram_per_ray = (st["dram.bytes"] + st.get("dram.bytes_written", 0)) / rays
        point = {
            "run": r,
            "rays_per_cycle": rays / st["time.cycles"],
            "dram_bound": st["machine.peak_dram_bytes_per_cycle"] / dram_per_ray if dram_per_ray > 0 else float("nan"),
            "trv_bound": st["machine.peak_trv_passes_per_cycle"] / (st["machine.trv_passes"] / rays),
        }
        ident = (r["scene"], r["builder"], r["preset"], r["fidelity"], json.dumps(others, sort_keys=True))
        series.setdefault(ident, {})[cores] = point
    series = OrderedDict((k, v) for k, v in series.items() if len(v) >= 2)
    if not series:
        return
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.6))
    xs_all = sorted({x for s in series.values() for x in s})
    drawn = []
    for i, ((scene, builder, preset, fidelity, others), points) in enumerate(series.items()):
        xs = sorted(points)
        colour = PRESET_COLOURS[i % len(PRESET_COLOURS)]
        label = "%s / %s" % (scene, builder)
        ax1.plot(xs, [points[x]["rays_per_cycle"] for x in xs], "o-", color=colour, label=label + ": measured")
        ax1.plot(xs, [points[x]["dram_bound"] for x in xs], "--", color=colour, label=label + ": DRAM bound")
        ax1.plot(xs, [points[x]["trv_bound"] for x in xs], ":", color=colour, label=label + ": TRV bound")
        ax2.plot(xs, [100 * points[x]["rays_per_cycle"] / min(points[x]["dram_bound"], points[x]["trv_bound"])
                      for x in xs], "o-", color=colour, label=label)
        for x in xs:
            drawn.append(drawn_value(points[x]["run"], points[x]["rays_per_cycle"], "rays.total / time.cycles",
                                     x=x, metric="rays per cycle"))
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
    figures.save(fig, "scaling_cores", "Scaling with RT cores",
                 "Left: rays per cycle (solid) against the number of RT cores on the %s machine, with the DRAM "
                 "bound (dashed: peak DRAM bytes per cycle / DRAM bytes read and written per ray at that core "
                 "count) and the TRV bound (dotted: the cores' box-test passes per cycle / passes per ray); no run "
                 "can lie above either. Right: the measured rate as a share of the lower bound: where it stays flat "
                 "the cores keep up with what memory allows." % preset, drawn)


if __name__ == "__main__":
    main()
