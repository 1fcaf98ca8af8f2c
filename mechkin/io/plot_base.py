"""What every PNG plot shares: the figure on an Agg canvas, colours, the atomic save, checks.

:func:`_new_figure` builds a ``matplotlib.figure.Figure`` on its own Agg canvas (never
``pyplot``: no global backend, no figure registry), :func:`_save` writes it through
:func:`mechkin.io.atomic.atomic_path` and releases it. Used by :mod:`mechkin.io.plots` and
:mod:`mechkin.io.stick_plots`. Split out of ``plots.py`` (issue 23: modules that fit in a
head).

Imports: numpy, matplotlib, mechkin.errors, io.atomic.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from mechkin.errors import OutputError
from mechkin.io.atomic import atomic_path

DPI = 120
MAX_PANELS = 12
MAX_SERIES = 12  # convergence: more series than this -> median, worst and 10-90 % band
_PANEL_COLS = 3
def _new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _colors(k: int) -> list[Any]:
    """k distinct colours: the default cycle up to 10, tab20 up to 20, else a continuous map."""
    from matplotlib import colormaps

    if k <= 10:
        return [f"C{i}" for i in range(k)]
    cmap = colormaps["tab20" if k <= 20 else "viridis"]
    return [cmap(i if k <= 20 else i / (k - 1)) for i in range(k)]


def _save(fig: Figure, path: str | os.PathLike[str]) -> Path:
    final = Path(path)
    if final.suffix.lower() != ".png":
        raise OutputError(f"{final}: expected a .png file name, got suffix {final.suffix!r}")
    try:
        with atomic_path(final) as tmp:
            fig.savefig(tmp, format="png")
    finally:
        fig.clear()
    return final


def _floats(x: object, what: str, ndim: int) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise OutputError(f"{what}: expected numbers, got {type(x).__name__}") from e
    if a.ndim != ndim:
        raise OutputError(f"{what}: expected a {ndim}-D array, got shape {a.shape}")
    return a
