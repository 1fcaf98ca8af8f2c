"""PNG plots: time series, 3-D stick drawings of mechanisms, convergence histories.

The stick drawings live in :mod:`mechkin.io.stick_plots` and what every figure shares in
:mod:`mechkin.io.plot_base`; their public names are re-exported here.

Figures are built with the object-oriented API (``matplotlib.figure.Figure`` on an Agg canvas),
never through ``pyplot``: no global backend is switched, no figure registry fills up, and
nothing depends on ``MPLBACKEND``. Each figure is released after saving, and saved through
:func:`mechkin.io.atomic.atomic_path`, so a failed plot leaves no partial PNG.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullLocator

from mechkin.errors import OutputError
from mechkin.io.plot_base import MAX_SERIES, _colors, _floats, _new_figure, _save
from mechkin.io.stick_plots import Plate, Stick, Triad, plot_stick_3d, stick_figure

__all__ = ["Plate", "Stick", "Triad", "convergence_figure", "plot_by_target",
           "plot_convergence", "plot_series", "plot_stick_3d", "stick_figure", "targets_figure"]


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
        ax.yaxis.set_minor_locator(NullLocator())  # decades only: minor ticks cost 1/3 here
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
