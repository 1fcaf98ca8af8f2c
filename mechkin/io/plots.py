"""PNG plots: time series, 3-D stick drawings of mechanisms, convergence histories.

Figures are built with the object-oriented API (``matplotlib.figure.Figure`` on an Agg canvas),
never through ``pyplot``: no global backend is switched, no figure registry fills up, and
nothing depends on ``MPLBACKEND``. Each figure is released after saving, and saved through
:func:`mechkin.io.atomic.atomic_path`, so a failed plot leaves no partial PNG.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from mechkin.errors import OutputError
from mechkin.io.atomic import atomic_path

__all__ = ["Stick", "convergence_figure", "plot_by_target", "plot_convergence", "plot_series",
           "plot_stick_3d", "targets_figure"]

DPI = 120
MAX_PANELS = 12
MAX_SERIES = 12  # convergence: more series than this -> median, worst and 10-90 % band
_PANEL_COLS = 3


@dataclass(frozen=True, eq=False)
class Stick:
    """A polyline of a stick drawing with its style.

    Parameters
    ----------
    points : array, shape (p, 3)
        Vertices [m].
    color : str or tuple, optional
        Any matplotlib colour; default from the colour cycle.
    linewidth : float
        Line width [pt].
    linestyle : str
        Matplotlib line style (``"-"``, ``"--"``, ``":"``).
    marker : str
        Marker at each vertex (``"o"`` for joints, ``""`` for none).
    label : str
        Legend entry (first panel only); empty for none.
    """

    points: np.ndarray
    color: str | tuple[float, ...] | None = None
    linewidth: float = 2.0
    linestyle: str = "-"
    marker: str = "o"
    label: str = ""


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


def plot_series(
    path: str | os.PathLike[str],
    t: np.ndarray,
    ys: np.ndarray,
    labels: Sequence[str],
    xlabel: str,
    ylabel: str,
    title: str,
    limits: Sequence[float] | None = None,
) -> Path:
    """Plot k curves against a common abscissa (e.g. joint trajectories), saved as PNG.

    Parameters
    ----------
    path : path-like
        Output ``.png``.
    t : array, shape (m,)
        Abscissa (time [s], path parameter ...).
    ys : array, shape (m, k)
        One column per curve; NaN leaves a gap.
    labels : sequence of k str
        Legend entries, with units (``"q1 [rad]"``).
    xlabel, ylabel, title : str
        Axis labels (with units) and title.
    limits : sequence of float, optional
        Values drawn as dashed horizontal lines (joint limits, strokes).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> plot_series(out / "q.png", t, q, ["q1 [rad]", "q2 [rad]"], "t [s]", "q [rad]",
    ...             "Joint trajectories", limits=[-1.57, 1.57])       # doctest: +SKIP
    """
    t = _floats(t, "t", 1)
    ys = _floats(ys, "ys", 2)
    if ys.shape[0] != t.shape[0]:
        raise OutputError(f"ys: expected shape ({t.shape[0]}, k), got {ys.shape}")
    if len(labels) != ys.shape[1]:
        raise OutputError(f"labels: expected {ys.shape[1]} labels, got {len(labels)}")
    fig = _new_figure((7.0, 4.0))
    ax = fig.add_subplot()
    for j, (label, color) in enumerate(zip(labels, _colors(len(labels)), strict=True)):
        ax.plot(t, ys[:, j], label=label, linewidth=1.5, color=color)
    for n, lim in enumerate(limits or ()):
        ax.axhline(float(lim), color="0.4", linestyle="--", linewidth=1.0,
                   label="limit" if n == 0 else None)
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title)
    ax.grid(True, alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize="small", ncols=1 + (len(labels) > 8))
    return _save(fig, path)


def _as_stick(item: np.ndarray | Stick, what: str) -> Stick:
    stick = item if isinstance(item, Stick) else Stick(points=np.asarray(item))
    pts = _floats(stick.points, what, 2)
    if pts.shape[1] != 3:
        raise OutputError(f"{what}: expected shape (p, 3), got {pts.shape}")
    return Stick(pts, stick.color, stick.linewidth, stick.linestyle, stick.marker, stick.label)


def _plane_square(point: np.ndarray, normal: np.ndarray, size: float) -> np.ndarray:
    """Corners (4, 3) of a square of side ``size`` centred at ``point``, normal ``normal``."""
    n = normal / np.linalg.norm(normal)
    helper = np.eye(3)[np.argmin(np.abs(n))]
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    h = 0.5 * size
    return point + h * np.array([u + v, -u + v, -u - v, u - v])


def plot_stick_3d(
    path: str | os.PathLike[str],
    snapshots: Sequence[Sequence[np.ndarray | Stick]],
    title: str,
    labels: Sequence[str] | None = None,
    planes: Sequence[tuple[np.ndarray, np.ndarray, float]] | None = None,
    *,
    overlay: bool = False,
    view: tuple[float, float] = (25.0, -60.0),
    markers: Sequence[np.ndarray | None] | None = None,
    marker_label: str = "target",
) -> Path:
    """Draw mechanism configurations as 3-D stick figures (one panel each, or overlaid).

    All panels share the same equal-aspect bounds, so sizes compare across snapshots, like the
    stick drawings of mechanisms in papers.

    Parameters
    ----------
    path : path-like
        Output ``.png``.
    snapshots : sequence of sequences of (array (p, 3) or Stick)
        One entry per configuration; each is the list of polylines to draw (links, legs,
        platform outline) [m]. Up to 12 panels (3 per row); any number when overlaid.
    title : str
        Figure title.
    labels : sequence of str, optional
        Panel titles (e.g. ``"t = 0.5 s"``); legend entries per snapshot when overlaid.
    planes : sequence of (point (3,), normal (3,), size), optional
        Planes drawn as translucent squares of side ``size`` [m] in every panel.
    overlay : bool
        Draw every snapshot in one panel, later ones darker.
    view : (float, float)
        Camera elevation and azimuth [deg].
    markers : sequence of (array (p, 3) or None), optional
        Points marked with a cross in each panel (e.g. the ik target) [m].
    marker_label : str
        Legend entry of those crosses.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> legs = [np.array([[0, 0, 0], [0.1, 0, 0.5]]), np.array([[0.2, 0, 0], [0.1, 0, 0.5]])]
    >>> plot_stick_3d(out / "poses.png", [legs], "Stewart platform")  # doctest: +SKIP
    """
    n = len(snapshots)
    if n == 0:
        raise OutputError("snapshots: expected at least one configuration, got none")
    if not overlay and n > MAX_PANELS:
        raise OutputError(f"snapshots: expected at most {MAX_PANELS} panels, got {n} "
                          f"(use overlay=True)")
    if labels is not None and len(labels) != n:
        raise OutputError(f"labels: expected {n} labels, got {len(labels)}")
    sticks = [[_as_stick(s, f"snapshots[{i}][{j}]") for j, s in enumerate(snap)]
              for i, snap in enumerate(snapshots)]
    squares = []
    for a, (point, normal, size) in enumerate(planes or ()):
        p, nv = _floats(point, f"planes[{a}].point", 1), _floats(normal, f"planes[{a}].normal", 1)
        if p.shape != (3,) or nv.shape != (3,) or not np.linalg.norm(nv) > 0:
            raise OutputError(f"planes[{a}]: expected a point (3,), a non-zero normal (3,) "
                              f"and a size")
        squares.append(_plane_square(p, nv, float(size)))

    if markers is not None and len(markers) != n:
        raise OutputError(f"markers: expected {n} entries, got {len(markers)}")
    marks = [None if mk is None else _floats(np.reshape(mk, (-1, 3)), f"markers[{i}]", 2)
             for i, mk in enumerate(markers or [None] * n)]
    every = ([s.points for snap in sticks for s in snap] + squares
             + [mk for mk in marks if mk is not None])
    pts = np.concatenate(every, axis=0) if every else np.zeros((1, 3))
    pts = pts[np.isfinite(pts).all(axis=1)]
    lo, hi = (pts.min(axis=0), pts.max(axis=0)) if len(pts) else (np.zeros(3), np.ones(3))
    centre, half = 0.5 * (lo + hi), 0.55 * max(float((hi - lo).max()), 1e-3)

    panels = 1 if overlay else n
    cols = 2 if panels == 4 else min(panels, _PANEL_COLS)  # 2x2, not 3 + 1 and 2 empty
    rows = math.ceil(panels / cols)
    fig = _new_figure((4.0 * cols, 3.8 * rows + 0.4))
    fig.suptitle(title)
    axes = [fig.add_subplot(rows, cols, k + 1, projection="3d") for k in range(panels)]
    for i, snap in enumerate(sticks):
        ax = axes[0 if overlay else i]
        alpha = 0.35 + 0.65 * (i + 1) / n if overlay else 1.0
        for j, s in enumerate(snap):
            label = s.label if (i == 0 or overlay) and s.label else None
            if overlay and labels is not None and j == 0:
                label = labels[i]
            color = s.color
            if color is None:
                color = f"C{(i if overlay else j) % 10}"
            ax.plot(s.points[:, 0], s.points[:, 1], s.points[:, 2], color=color,
                    linewidth=s.linewidth, linestyle=s.linestyle, marker=s.marker or "None",
                    markersize=3.5, alpha=alpha, label=label)
        if marks[i] is not None:
            mk = marks[i]
            ax.scatter(mk[:, 0], mk[:, 1], mk[:, 2], marker="x", s=40, color="tab:red",
                       depthshade=False, label=marker_label if i == 0 else None)
        if labels is not None and not overlay:
            ax.set_title(labels[i], fontsize="medium")
    for ax in axes:
        for sq in squares:
            ax.add_collection3d(Poly3DCollection([sq], facecolor=(0.5, 0.6, 0.8, 0.25),
                                                 edgecolor=(0.3, 0.3, 0.5, 0.6)))
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)
        ax.set_box_aspect((1.0, 1.0, 1.0), zoom=0.82)  # room for the z label
        ax.view_init(elev=view[0], azim=view[1])
        ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]")
        ax.tick_params(labelsize="x-small")
    if axes[0].get_legend_handles_labels()[0]:
        axes[0].legend(loc="upper left", fontsize="x-small")
    return _save(fig, path)


def convergence_figure(
    values_per_series: Mapping[str, np.ndarray | Sequence[float]],
    ylabel: str,
    logy: bool = True,
    *,
    xlabel: str = "iteration",
    title: str = "Convergence",
) -> Figure:
    """The figure of :func:`plot_convergence` (not saved).

    Up to ``MAX_SERIES`` series: one line each, every line its own colour. More: a summary
    over the series -- median and worst (largest) value per iteration and the shaded 10-90 %
    band -- where a series that stopped early keeps its last value.
    """
    if not values_per_series:
        raise OutputError("values_per_series: expected at least one series, got none")
    series = {name: _floats(v, f"values_per_series[{name!r}]", 1)
              for name, v in values_per_series.items()}
    fig = _new_figure((6.5, 4.0))
    ax = fig.add_subplot()

    def shown(v: np.ndarray) -> np.ndarray:
        return np.where(v > 0, v, np.nan) if logy else v

    if len(series) <= MAX_SERIES:
        for (name, v), color in zip(series.items(), _colors(len(series)), strict=True):
            ax.plot(np.arange(v.shape[0]), shown(v), marker=".", markersize=4, label=name,
                    color=color)
    else:
        n_it = max(v.shape[0] for v in series.values())
        table = np.full((len(series), n_it), np.nan)
        for r, v in enumerate(series.values()):
            if v.shape[0]:
                table[r, :v.shape[0]] = v
                table[r, v.shape[0]:] = v[-1]
        it = np.arange(n_it)
        lo, med, hi = np.nanpercentile(table, [10.0, 50.0, 90.0], axis=0)
        worst = np.nanmax(table, axis=0)
        ax.fill_between(it, shown(lo), shown(hi), color="C0", alpha=0.25,
                        label=f"10-90 % of {len(series)} runs")
        ax.plot(it, shown(med), color="C0", linewidth=1.8, label="median")
        ax.plot(it, shown(worst), color="C3", linewidth=1.2, linestyle="--", label="worst")
    if logy:
        ax.set_yscale("log", nonpositive="mask")
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title)
    ax.grid(True, which="both" if logy else "major", alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize="small", ncols=1 + (len(series) > 6
                                                           and len(series) <= MAX_SERIES))
    return fig


def plot_convergence(
    path: str | os.PathLike[str],
    values_per_series: Mapping[str, np.ndarray | Sequence[float]],
    ylabel: str,
    logy: bool = True,
    *,
    xlabel: str = "iteration",
    title: str = "Convergence",
) -> Path:
    """Plot per-iteration histories (objective f, residual norm) of one or more solver runs.

    Parameters
    ----------
    path : path-like
        Output ``.png``.
    values_per_series : mapping of str to array, shape (n_iter,)
        Legend entry -> value at iterations 0, 1, ...; lengths may differ. More than
        ``MAX_SERIES`` (12) entries are summarised (median, worst, 10-90 % band).
    ylabel : str
        Axis label with units (``"f [m^2]"``).
    logy : bool
        Logarithmic y axis; values <= 0 (an exact zero at convergence) are left out.
    xlabel, title : str
        Abscissa label and title.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> plot_convergence(out / "f.png", {"CG": f_cg, "LM": f_lm}, "f")  # doctest: +SKIP
    """
    return _save(convergence_figure(values_per_series, ylabel, logy, xlabel=xlabel, title=title),
                 path)


MAX_TICK_LABELS = 30


def targets_figure(
    targets: Sequence[str],
    values: np.ndarray,
    labels: Sequence[str],
    ylabel: str,
    title: str,
    errors: Mapping[str, np.ndarray] | None = None,
) -> Figure:
    """Dot plot of values per named target (ik: joint values, errors) on a categorical axis.

    Parameters
    ----------
    targets : sequence of m str
        Target names: the tick labels of the abscissa.
    values : array, shape (m, k)
        One column per series (joint), one dot per target.
    labels : sequence of k str
        Legend entries with units.
    ylabel, title : str
        Ordinate label (with units) of the value panel, and the figure title.
    errors : mapping of str to array (m,), optional
        Ordinate label -> one value per target, each drawn below as a log-scale dot panel
        (position error [m], orientation error [rad]); values <= 0 are left out.

    Returns
    -------
    Figure
        The figure (constrained layout), not saved.
    """
    values = _floats(values, "values", 2)
    m = len(targets)
    if values.shape[0] != m:
        raise OutputError(f"values: expected shape ({m}, k), got {values.shape}")
    if len(labels) != values.shape[1]:
        raise OutputError(f"labels: expected {values.shape[1]} labels, got {len(labels)}")
    errs = dict(errors or {})
    fig = _new_figure((max(6.5, 0.35 * min(m, MAX_TICK_LABELS) + 3.0),
                       3.6 + 1.9 * len(errs)))
    axes = fig.subplots(1 + len(errs), 1, sharex=True, squeeze=False,
                        height_ratios=[2.0] + [1.0] * len(errs))[:, 0]
    x = np.arange(m)
    k = values.shape[1]
    width = 0.6 / max(k, 1)
    for j, (label, color) in enumerate(zip(labels, _colors(k), strict=True)):
        axes[0].plot(x + (j - 0.5 * (k - 1)) * width, values[:, j], linestyle="none",
                     marker="o", markersize=4, label=label, color=color)
    axes[0].set(ylabel=ylabel, title=title)
    for ax, (name, e) in zip(axes[1:], errs.items(), strict=True):
        v = _floats(e, f"errors[{name!r}]", 1)
        ax.plot(x, np.where(v > 0, v, np.nan), linestyle="none", marker="s", markersize=4,
                color="0.25")
        ax.set_yscale("log", nonpositive="mask")
        ax.set_ylabel(name)
    step = max(1, math.ceil(m / MAX_TICK_LABELS))
    last = axes[-1]
    last.set_xticks(x[::step], [str(t) for t in targets][::step],
                    rotation=45 if m > 6 else 0, ha="right" if m > 6 else "center")
    last.set_xlabel("target")
    last.set_xlim(-0.6, m - 0.4)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    if axes[0].get_legend_handles_labels()[0]:
        axes[0].legend(loc="best", fontsize="small", ncols=1 + (k > 8))
    return fig


def plot_by_target(
    path: str | os.PathLike[str],
    targets: Sequence[str],
    values: np.ndarray,
    labels: Sequence[str],
    ylabel: str,
    title: str,
    errors: Mapping[str, np.ndarray] | None = None,
) -> Path:
    """Save :func:`targets_figure` as a PNG and return ``path``."""
    return _save(targets_figure(targets, values, labels, ylabel, title, errors), path)
