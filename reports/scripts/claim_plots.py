#!/usr/bin/env python3
"""Pictures for `rtsim claim`: one heatmap per relation, rows = scene/camera,
columns = conditions, one panel per metric (rows) and ray mix (columns). Colour:
the mean effect in % (blue = the relation holds in the mean, red = reversed),
marked 'H' where the 95% interval is below zero and 'R' where it is above.

Usage: claim_plots.py OUT_DIR   (reads OUT_DIR/claim.json)
"""
import json
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from plot_files import save  # noqa: E402

METRICS = [("ops", "TRV+IST ops/ray"), ("node_fetches", "node fetches/ray"), ("dram_bytes", "DRAM B/ray")]
MIXES = ["primary", "ao", "all"]



def picture_name(relation):
    return "claim_" + relation.replace("<", "-lt-", 1) + ".png"


def main(out_dir):
    with open(os.path.join(out_dir, "claim.json")) as f:
        claim = json.load(f)
    cells = claim["cells"]
    for rel in claim["relations"]:
        mine = [c for c in cells if c["relation"] == rel["name"]]
        if not mine:
            continue
        rows = list(dict.fromkeys(c["scene"] + "/" + c["camera"] for c in mine))
        present = set(c["condition"] for c in mine)
        cols = [c for c in claim.get("conditions", []) if c in present] or sorted(present)
        fig, axes = plt.subplots(len(METRICS), len(MIXES), squeeze=False,
                                 figsize=(3.2 + max(3.0, 0.55 * len(cols)) * len(MIXES), 2.4 + (0.8 + 0.3 * len(rows)) * len(METRICS)),
                                 gridspec_kw={"hspace": 0.45})
        for i, (metric, metric_text) in enumerate(METRICS):
            for j, mix in enumerate(MIXES):
                ax = axes[i][j]
                grid = np.full((len(rows), len(cols)), np.nan)
                marks = {}
                for c in mine:
                    if c["metric"] != metric or c["mix"] != mix:
                        continue
                    r = rows.index(c["scene"] + "/" + c["camera"])
                    k = cols.index(c["condition"])
                    if c["mean_pct"] is not None and c["verdict"] != "n/a":
                        grid[r, k] = c["mean_pct"]
                    marks[(r, k)] = {"holds": "H", "reverses": "R"}.get(c["verdict"], "")
                limit = max(5.0, min(40.0, np.nanmax(np.abs(grid)) if np.isfinite(grid).any() else 5.0))
                im = ax.imshow(grid, cmap="RdBu_r", vmin=-limit, vmax=limit, aspect="auto")
                for (r, k), m in marks.items():
                    if m:
                        ax.text(k, r, m, ha="center", va="center", fontsize=7)
                ax.set_xticks(range(len(cols)))
                ax.set_xticklabels(cols if i == len(METRICS) - 1 else [], rotation=60, ha="right", fontsize=7)
                ax.set_yticks(range(len(rows)))
                ax.set_yticklabels(rows if j == 0 else [], fontsize=7)
                ax.set_title(f"{metric_text}, {mix} rays", fontsize=8)
                fig.colorbar(im, ax=ax, fraction=0.04, pad=0.02).ax.tick_params(labelsize=6)
        fig.suptitle(f"{rel['text']}: mean difference in % (H: holds, R: reverses, 95% interval)", fontsize=10)
        save(fig, os.path.join(out_dir, picture_name(rel["name"])), dpi=100)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
