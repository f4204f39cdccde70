"""Shared by the plot scripts: writing a picture atomically."""
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def save(fig, path, dpi=110):
    """Write fig to path through a temporary file: never a half-written picture."""
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=dpi, bbox_inches="tight")
    os.replace(tmp, path)
    plt.close(fig)
