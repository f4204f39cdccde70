"""Shared by the plot scripts: writing pictures and data atomically."""
import json
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def write_json(path, value):
    """Write value as JSON to path through a temporary file."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(value, f, indent=1)
        f.write("\n")
    os.replace(tmp, path)


def save(fig, path, dpi=110, data=None):
    """Write fig to path through a temporary file: never a half-written picture. With
    data (what the figure drew), write it beside the picture as <name>.data.json, so a
    test can hold the figure to the numbers it shows."""
    if data is not None:
        write_json(os.path.splitext(path)[0] + ".data.json", data)
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=dpi, bbox_inches="tight")
    os.replace(tmp, path)
    plt.close(fig)
