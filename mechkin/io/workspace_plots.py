"""Workspace figures: sigma_KI contour maps (lee Figs. 3-5), gamma_min/gamma_max (lee Fig. 2),
design-sweep panels, task-space dexterity and joint-sweep point clouds.

Plot functions take plain arrays or records (:mod:`mechkin.records.workspace`; radians in,
degrees on the axes) and never import solvers; :mod:`mechkin.io.workspace_out` calls them.
Figures are drawn on the Agg canvas without pyplot (no global state) and every PNG is written to
a temp name and renamed (:func:`mechkin.io.atomic.atomic_path`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from mechkin.io.atomic import atomic_path

if TYPE_CHECKING:
    from mechkin.records.workspace import TaskSpaceRecord

__all__ = [
    "plot_design_gamma_range",
    "plot_design_isotropy",
    "plot_gamma_range",
    "plot_isotropy_maps",
    "plot_point_cloud",
    "plot_task_space",
]

_SIGMA_LEVELS = np.linspace(0.0, 1.0, 21)
_SIGMA_LINES = np.round(np.arange(0.1, 1.0, 0.1), 1)
_OUT_COLOR = "0.82"


def _deg(x: np.ndarray) -> np.ndarray:
    """Radians -> degrees rounded to 1e-9 deg, so 30 deg is written 30.0, not 29.999999999999996."""
    return np.round(np.rad2deg(x), 9)


def _figure(figsize: tuple[float, float]) -> Figure:
    """A constrained-layout figure on its Agg canvas from the start: a figure without one
    answers every renderer request of contour labels, colour bars and text extents by a dry
    run of a whole savefig (29 of them for one lee map, half its time)."""
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: str | os.PathLike[str], dpi: int) -> Path:
    final = Path(path)
    with atomic_path(final) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    return final


def _sigma_panel(ax: Any, a_deg: np.ndarray, b_deg: np.ndarray, sigma: np.ndarray,
                 within: np.ndarray, threshold: float) -> Any:
    """One sigma_KI contour panel over alpha-beta (grey outside the strokes); returns the
    filled contour set (for the colour bar)."""
    S = np.asarray(sigma, dtype=np.float64).T  # (n_b, n_a): rows follow beta (y)
    inside = np.asarray(within, dtype=bool).T
    ax.set_facecolor("white")
    cf = ax.contourf(
        a_deg,
        b_deg,
        np.ma.masked_where(~inside, S),
        levels=_SIGMA_LEVELS,
        cmap="viridis",
        vmin=0.0,
        vmax=1.0,
    )
    if (~inside).any():
        ax.contourf(
            a_deg,
            b_deg,
            (~inside).astype(float),
            levels=[0.5, 1.5],
            cmap=ListedColormap([_OUT_COLOR]),
        )
    if np.ptp(S) > 0:
        cs = ax.contour(
            a_deg,
            b_deg,
            np.ma.masked_where(~inside, S),
            levels=_SIGMA_LINES,
            colors="k",
            linewidths=0.6,
        )
        ax.clabel(cs, fmt="%.1f", fontsize=7, inline_spacing=2)
        if S.min() < threshold < S.max():
            ax.contour(
                a_deg,
                b_deg,
                np.ma.masked_where(~inside, S),
                levels=[threshold],
                colors="red",
                linewidths=1.0,
                linestyles="--",
            )
    ax.set_aspect("equal")
    return cf


def plot_isotropy_maps(
    path: str | os.PathLike[str],
    alpha: np.ndarray,
    beta: np.ndarray,
    gammas: Sequence[float] | np.ndarray,
    sigma: np.ndarray,
    within_limits: np.ndarray,
    *,
    threshold: float = 0.01,
    title: str = "",
    dpi: int = 120,
) -> Path:
    """sigma_KI contour maps over the alpha-beta plane, one panel per gamma (lee Figs. 3-5).

    Poses outside the leg strokes are drawn grey (not coloured by sigma_KI); the dashed red
    line is ``sigma_KI = threshold``, the workspace boundary due to singularity.

    Parameters
    ----------
    path : path-like
        PNG file to write.
    alpha, beta : array, shapes (n_a,), (n_b,)
        Grid axes [rad].
    gammas : array, shape (n_g,)
        [rad], one panel each.
    sigma : array, shape (n_g, n_a, n_b)
    within_limits : array of bool, shape (n_g, n_a, n_b)
    threshold : float
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    a_deg, b_deg = np.rad2deg(alpha), np.rad2deg(beta)
    gammas = np.atleast_1d(np.asarray(gammas, dtype=np.float64))
    n = gammas.size
    fig = _figure((4.3 * n + 1.0, 4.6))
    axes = fig.subplots(1, n, squeeze=False)[0]
    cf = None
    for g, ax in enumerate(axes):
        cf = _sigma_panel(ax, a_deg, b_deg, sigma[g], within_limits[g], threshold)
        ax.set_title(f"({chr(ord('a') + g)}) $\\gamma$ = {np.rad2deg(gammas[g]):g}°")
        ax.set_xlabel(r"$\alpha$ [deg]")
        ax.set_ylabel(r"$\beta$ [deg]")
        ax.set_aspect("equal")
    if cf is not None:
        cb = fig.colorbar(cf, ax=list(axes), shrink=0.85, ticks=np.linspace(0, 1, 11))
        cb.set_label(r"$\sigma_{KI}$")
    note = f"grey: leg outside stroke; red dashed: $\\sigma_{{KI}}$ = {threshold:g}"
    fig.suptitle(f"{title}\n{note}" if title else note, fontsize=10)
    return _save(fig, path, dpi)


def plot_gamma_range(
    path: str | os.PathLike[str],
    alpha: np.ndarray,
    beta: np.ndarray,
    gamma_min: np.ndarray,
    gamma_max: np.ndarray,
    *,
    title: str = "",
    dpi: int = 120,
) -> Path:
    """gamma_min and gamma_max over the alpha-beta plane as 3-D surfaces and contours (lee Fig. 2).

    Panels: (a) 3-D plot and (b) contour plot of gamma_min, (c) 3-D plot and (d) contour plot
    of gamma_max. Grid points without workspace (NaN) are left blank.

    Parameters
    ----------
    path : path-like
        PNG file to write.
    alpha, beta : array, shapes (n_a,), (n_b,)
        [rad].
    gamma_min, gamma_max : array, shape (n_a, n_b)
        [rad], NaN where undefined.
    title : str

    Returns
    -------
    Path
    """
    a_deg, b_deg = np.rad2deg(alpha), np.rad2deg(beta)
    A, B = np.meshgrid(a_deg, b_deg, indexing="ij")
    fig = _figure((11.0, 9.6))
    panels = (("min", gamma_min, "a", "b"), ("max", gamma_max, "c", "d"))
    for row, (which, G, l3, l2) in enumerate(panels):
        Gd = np.rad2deg(np.asarray(G, dtype=np.float64))
        finite = np.isfinite(Gd)
        label = f"$\\gamma_{{{which}}}$ [deg]"
        ax3 = fig.add_subplot(2, 2, 2 * row + 1, projection="3d")
        ax2 = fig.add_subplot(2, 2, 2 * row + 2)
        if finite.any():
            lo, hi = float(Gd[finite].min()), float(Gd[finite].max())
            if hi <= lo:
                hi = lo + 1.0
            levels = MaxNLocator(nbins=14).tick_values(lo, hi)
            Z = np.where(finite, Gd, np.nan)
            ax3.plot_surface(
                A,
                B,
                np.ma.masked_invalid(Z),
                cmap="viridis",
                vmin=lo,
                vmax=hi,
                rcount=40,  # at most 40 x 40 facets (every grid point: ~1 s more per panel)
                ccount=40,
                linewidth=0,
                antialiased=False,
            )
            Zm = np.ma.masked_invalid(Z).T
            cf = ax2.contourf(a_deg, b_deg, Zm, levels=levels, cmap="viridis")
            cs = ax2.contour(
                a_deg,
                b_deg,
                Zm,
                levels=levels[1:-1:2],
                colors="k",
                linewidths=0.6,
            )
            ax2.clabel(cs, fmt="%.0f", fontsize=7)
            fig.colorbar(cf, ax=ax2, label=label, shrink=0.9)
        else:  # nothing defined: say so instead of two empty panels
            for ax in (ax2, ax3):
                ax.set_axis_off()
            ax2.text(0.5, 0.5, f"$\\gamma_{{{which}}}$ undefined on the whole grid",
                     ha="center", va="center", transform=ax2.transAxes)
        ax3.set_box_aspect(None, zoom=0.85)  # room for the z label under constrained layout
        ax3.set_xlabel(r"$\alpha$ [deg]")
        ax3.set_ylabel(r"$\beta$ [deg]")
        ax3.set_zlabel(label)
        ax3.set_title(f"({l3}) 3-D plot of $\\gamma_{{{which}}}$")
        ax3.view_init(elev=28, azim=-125)
        ax2.set_xlabel(r"$\alpha$ [deg]")
        ax2.set_ylabel(r"$\beta$ [deg]")
        ax2.set_aspect("equal")
        ax2.set_title(f"({l2}) contour plot of $\\gamma_{{{which}}}$ (blank: no workspace)")
    if title:
        fig.suptitle(title, fontsize=11)
    return _save(fig, path, dpi)


# --------------------------------------------------------------------------- design sweeps


def _value_label(parameter: str, value: float) -> str:
    return f"{parameter} = {value:g}"


def plot_design_isotropy(
    path: str | os.PathLike[str],
    parameter: str,
    values: Sequence[float],
    maps: Sequence[Any],
    *,
    title: str = "",
    dpi: int = 100,
) -> Path:
    """sigma_KI maps of a design sweep side by side: a row per design value, a column per gamma.

    Parameters
    ----------
    path : path-like
    parameter : str
        Name of the swept parameter (row labels).
    values : sequence of float
    maps : sequence of OrientationMaps
        ``maps[i]`` for ``values[i]``; all on the same gammas.
    title : str

    Returns
    -------
    Path
    """
    n_r = len(values)
    n_c = int(np.asarray(maps[0].gamma).size)
    fig = _figure((3.6 * n_c + 1.2, 3.4 * n_r + 0.8))
    axes = fig.subplots(n_r, n_c, squeeze=False)
    cf = None
    for i, (v, mp) in enumerate(zip(values, maps, strict=True)):
        a_deg, b_deg = np.rad2deg(mp.alpha), np.rad2deg(mp.beta)
        for g in range(n_c):
            ax = axes[i, g]
            cf = _sigma_panel(ax, a_deg, b_deg, mp.sigma[g], mp.within_limits[g], mp.threshold)
            frac = float(np.mean(mp.in_workspace[g]))
            ax.set_title(f"{_value_label(parameter, v)}, $\\gamma$ = "
                         f"{np.rad2deg(mp.gamma[g]):g}° (area {frac:.3f})", fontsize=9)
            ax.set_xlabel(r"$\alpha$ [deg]" if i == n_r - 1 else "")
            ax.set_ylabel(r"$\beta$ [deg]" if g == 0 else "")
    if cf is not None:
        cb = fig.colorbar(cf, ax=axes.ravel().tolist(), shrink=0.6, ticks=np.linspace(0, 1, 11))
        cb.set_label(r"$\sigma_{KI}$")
    note = (f"grey: leg outside stroke; red dashed: $\\sigma_{{KI}}$ = {maps[0].threshold:g}; "
            "area: in-workspace fraction of the grid")
    fig.suptitle(f"{title}\n{note}" if title else note, fontsize=10)
    return _save(fig, path, dpi)


def plot_design_gamma_range(
    path: str | os.PathLike[str],
    parameter: str,
    values: Sequence[float],
    ranges: Sequence[Any],
    *,
    title: str = "",
    dpi: int = 100,
) -> Path:
    """gamma_min / gamma_max contour maps of a design sweep: a row per value (lee Fig. 2)."""
    n_r = len(values)
    fig = _figure((9.0, 3.6 * n_r + 0.8))
    axes = fig.subplots(n_r, 2, squeeze=False)
    for i, (v, gr) in enumerate(zip(values, ranges, strict=True)):
        a_deg, b_deg = np.rad2deg(gr.alpha), np.rad2deg(gr.beta)
        for j, (which, G) in enumerate((("min", gr.gamma_min), ("max", gr.gamma_max))):
            ax = axes[i, j]
            Gd = np.rad2deg(np.asarray(G, dtype=np.float64))
            fin = np.isfinite(Gd)
            if fin.any():
                lo, hi = float(Gd[fin].min()), float(Gd[fin].max())
                levels = MaxNLocator(nbins=14).tick_values(lo, hi if hi > lo else lo + 1.0)
                cf = ax.contourf(a_deg, b_deg, np.ma.masked_invalid(Gd).T, levels=levels,
                                 cmap="viridis")
                fig.colorbar(cf, ax=ax, shrink=0.9, label=f"$\\gamma_{{{which}}}$ [deg]")
            ax.set_aspect("equal")
            ax.set_title(f"{_value_label(parameter, v)}: $\\gamma_{{{which}}}$ "
                         f"(defined on {float(fin.mean()):.3f})", fontsize=9)
            ax.set_xlabel(r"$\alpha$ [deg]" if i == n_r - 1 else "")
            ax.set_ylabel(r"$\beta$ [deg]" if j == 0 else "")
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path, dpi)


# --------------------------------------------------------------------------- task space


def plot_task_space(
    path: str | os.PathLike[str],
    rec: TaskSpaceRecord,
    *,
    title: str = "",
    dpi: int = 100,
) -> Path:
    """Reachability and dexterity of task-space poses, projected on the plane of the two
    position coordinates that vary most: (a) isotropy, (b) position-row isotropy, (c)
    Yoshikawa manipulability; unreached poses are grey crosses."""
    P = rec.T_P[:, :3, 3]
    spread = np.ptp(P, axis=0) if P.shape[0] else np.zeros(3)
    i, j = sorted(np.argsort(-spread, kind="stable")[:2])
    names = "xyz"
    ok = rec.reachable
    fig = _figure((15.0, 4.8))
    axes = fig.subplots(1, 3)
    panels = (("isotropy", rec.isotropy, "isotropy $\\sigma_{min}/\\sigma_{max}$", (0, 1)),
              ("isotropy_position", rec.isotropy_position, "isotropy, position rows", (0, 1)),
              ("manipulability", rec.manipulability, "manipulability $\\prod \\sigma_i$",
               None))
    size = max(4.0, min(60.0, 12000.0 / max(1, P.shape[0])))
    for ax, (_, val, label, lim) in zip(axes, panels, strict=True):
        if (~ok).any():
            ax.scatter(P[~ok, i], P[~ok, j], s=size * 0.6, c=_OUT_COLOR, marker="x",
                       label="not reached")
        if ok.any():
            kw: dict[str, Any] = {"vmin": lim[0], "vmax": lim[1]} if lim else {}
            sc = ax.scatter(P[ok, i], P[ok, j], s=size, c=val[ok], cmap="viridis", **kw)
            fig.colorbar(sc, ax=ax, shrink=0.85, label=label)
        ax.set_xlabel(f"{names[i]} [m]")
        ax.set_ylabel(f"{names[j]} [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(label, fontsize=10)
        if (~ok).any():
            ax.legend(loc="upper right", fontsize=7)
    fig.suptitle(title or "task-space sweep", fontsize=11)
    return _save(fig, path, dpi)


# --------------------------------------------------------------------------- joint sweeps


MAX_SCATTER = 4000  # more points per panel: a binned image (scatter markers cost ~0.1 ms each)
_BINS = 120


def _cloud(ax: Any, x: np.ndarray, y: np.ndarray, colour: np.ndarray | None,
           kw: dict[str, Any]) -> Any:
    """Points (x, y) of a cloud: a scatter up to ``MAX_SCATTER`` points; more as an image of
    ``_BINS`` square bins, each bin the mean colour of its points (or uniform), empty bins
    blank. Returns the mappable for a colour bar."""
    if len(x) <= MAX_SCATTER:
        return ax.scatter(x, y, linewidths=0, **kw)
    lo = np.array([x.min(), y.min()])
    span = max(float(np.ptp(x)), float(np.ptp(y)), 1e-12)
    nx = max(1, int(np.ceil(_BINS * np.ptp(x) / span)))
    ny = max(1, int(np.ceil(_BINS * np.ptp(y) / span)))
    ex = lo[0] + np.arange(nx + 1) * span / _BINS
    ey = lo[1] + np.arange(ny + 1) * span / _BINS
    count, _, _ = np.histogram2d(x, y, bins=(ex, ey))
    if colour is not None:
        total, _, _ = np.histogram2d(x, y, bins=(ex, ey), weights=colour)
        with np.errstate(invalid="ignore", divide="ignore"):
            img = np.where(count > 0, total / count, np.nan)
        cmap, vmin, vmax = "viridis", 0.0, 1.0
    else:
        img = np.where(count > 0, 1.0, np.nan)
        from matplotlib.colors import ListedColormap

        cmap, vmin, vmax = ListedColormap(["tab:blue"]), 0.0, 1.0
    return ax.imshow(img.T, origin="lower", extent=(ex[0], ex[-1], ey[0], ey[-1]),
                     interpolation="nearest", cmap=cmap, vmin=vmin, vmax=vmax, aspect="auto")


def plot_point_cloud(path: str | os.PathLike[str], P: np.ndarray, colour: np.ndarray | None,
                     slices: dict[str, Any] | None, *, title: str) -> None:
    """Three projections of the point cloud ``P`` (k, 3) [m] and up to three slabs normal to
    one axis (``slices``: ``axis``, ``at`` plane offsets [m] or None for the quartiles,
    ``thickness`` [m] or None for 1/25 of the extent); coloured by ``colour`` in [0, 1]."""
    axis_names = "xyz"
    k = axis_names.index(slices["axis"]) if slices is not None else 2
    extent = float(np.ptp(P, axis=0).max()) or 1.0
    if slices is not None and slices["at"]:
        planes = list(slices["at"])[:3]
    else:
        planes = [float(np.quantile(P[:, k], qq)) for qq in (0.25, 0.5, 0.75)]
    thick = slices["thickness"] if (slices is not None and slices["thickness"]) else extent / 25.0
    others = [i for i in range(3) if i != k]
    fig = _figure((14, 9))
    c = colour if colour is not None else "tab:blue"
    kw = {"s": 2, "c": c, "cmap": "viridis", "vmin": 0.0, "vmax": 1.0} if colour is not None \
        else {"s": 2, "c": c}
    sc_ = None
    for p, (i, j) in enumerate([(0, 1), (0, 2), (1, 2)]):
        ax = fig.add_subplot(2, 3, p + 1)
        sc_ = _cloud(ax, P[:, i], P[:, j], colour, kw)
        ax.set_xlabel(f"{axis_names[i]} [m]")
        ax.set_ylabel(f"{axis_names[j]} [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"projection on {axis_names[i]}{axis_names[j]}")
    for p, z in enumerate(planes):
        ax = fig.add_subplot(2, 3, 4 + p)
        sel = np.abs(P[:, k] - z) <= thick / 2
        ckw = dict(kw)
        if colour is not None:
            ckw["c"] = colour[sel]
        _cloud(ax, P[sel, others[0]], P[sel, others[1]],
               None if colour is None else colour[sel], ckw)
        ax.set_xlabel(f"{axis_names[others[0]]} [m]")
        ax.set_ylabel(f"{axis_names[others[1]]} [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"slice {axis_names[k]} = {z:.3g} m ± {thick / 2:.2g}\n"
                     f"({int(sel.sum())} points)", fontsize=9)
    if colour is not None and sc_ is not None:
        fig.colorbar(sc_, ax=fig.axes, shrink=0.6, label="isotropy (position rows)")
    fig.suptitle(title, fontsize=11)
    _save(fig, path, 100)
