"""Figures as PNG files: matplotlib without pyplot's global state, written atomically.

matplotlib is an optional dependency (``pip install '.[plot]'``): without it
a figure is a clear RuntimeError, which the command lines turn into one line.
"""

from __future__ import annotations

import os

from .atomic import AtomicFile


def figure(width_in: float, height_in: float):
    """A matplotlib Figure (no pyplot, no global state), or a clear error without matplotlib."""
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise RuntimeError("matplotlib is not installed: pip install '.[plot]'") from None
    return Figure(figsize=(width_in, height_in), layout="tight")


def save_png(fig, path: str | os.PathLike) -> None:
    """Write the figure as PNG atomically (ARCHITECTURE.md: nothing saved is half-written)."""
    with AtomicFile(path, "wb") as f:
        fig.savefig(f.file, format="png", dpi=120)
