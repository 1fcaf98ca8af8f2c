"""Workspace figures: sigma_KI contour maps (lee Figs. 3-5) and gamma_min/gamma_max (lee Fig. 2).

Plot functions take plain arrays (radians in, degrees on the axes) and never import solvers.
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

from mechkin.io.atomic import OutputDir, atomic_path

if TYPE_CHECKING:
    from mechkin.solvers.workspace import LeeWorkspaceRecord

__all__ = ["plot_gamma_range", "plot_isotropy_maps", "write_lee_workspace"]

_SIGMA_LEVELS = np.linspace(0.0, 1.0, 21)
_SIGMA_LINES = np.round(np.arange(0.1, 1.0, 0.1), 1)
_OUT_COLOR = "0.82"


def _deg(x: np.ndarray) -> np.ndarray:
    """Radians -> degrees rounded to 1e-9 deg, so 30 deg is written 30.0, not 29.999999999999996."""
    return np.round(np.rad2deg(x), 9)


def _save(fig: Figure, path: str | os.PathLike[str], dpi: int) -> Path:
    FigureCanvasAgg(fig)
    final = Path(path)
    with atomic_path(final) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    return final


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
    fig = Figure(figsize=(4.3 * n + 1.0, 4.6), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)[0]
    cf = None
    for g, ax in enumerate(axes):
        S = np.asarray(sigma[g], dtype=np.float64).T  # (n_b, n_a): rows follow beta (y)
        inside = np.asarray(within_limits[g], dtype=bool).T
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
    fig = Figure(figsize=(11.0, 9.6), layout="constrained")
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
                rstride=1,
                cstride=1,
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


def write_lee_workspace(
    record: LeeWorkspaceRecord,
    out_dir: str | os.PathLike[str],
    *,
    plots: bool = True,
    csv: bool = True,
) -> list[str]:
    """Write the figures, CSV grids and summary.json of a lee workspace record.

    Files (in ``out_dir``): per gamma set ``NAME`` of ``record.isotropy``:
    ``sigma_ki_NAME.png`` and ``sigma_ki_NAME.csv`` (one row per grid pose: ``alpha_deg,
    beta_deg, gamma_deg, l1_m, l2_m, l3_m, sigma_ki, within_stroke, in_workspace``); when the
    gamma range was computed: ``gamma_range.png`` and ``gamma_range.csv`` (``alpha_deg,
    beta_deg, n_gamma_in, n_runs, gamma_min_deg, gamma_max_deg``, only rows where gamma_min is
    defined; their count is in summary.json); and ``summary.json``. Lengths are in units of
    the base radius ``R`` (written ``_m``). All files appear together or not at all.

    Returns
    -------
    list of str
        Names written, relative to ``out_dir``.
    """
    geom = record.geometry
    summary: dict[str, Any] = dict(record.summary)
    with OutputDir(out_dir) as od:
        for name, maps in record.isotropy.items():
            gam_txt = "/".join(f"{g:g}" for g in _deg(maps.gamma))
            if plots:
                plot_isotropy_maps(
                    od.path_for(f"sigma_ki_{name}.png"),
                    maps.alpha,
                    maps.beta,
                    maps.gamma,
                    maps.sigma,
                    maps.within_limits,
                    threshold=maps.threshold,
                    title=f"lee: $\\sigma_{{KI}}$ over $\\alpha$-$\\beta$, r = {geom.r:g}, "
                    f"$\\gamma$ = {gam_txt}° ({name})",
                )
            if csv:
                G, A, B = np.meshgrid(maps.gamma, maps.alpha, maps.beta, indexing="ij")
                cols: dict[str, np.ndarray] = {
                    "alpha_deg": _deg(A).ravel(),
                    "beta_deg": _deg(B).ravel(),
                    "gamma_deg": _deg(G).ravel(),
                }
                if maps.actuators is not None:
                    for i in range(maps.actuators.shape[-1]):
                        cols[f"l{i + 1}_m"] = maps.actuators[..., i].ravel()
                cols["sigma_ki"] = maps.sigma.ravel()
                cols["within_stroke"] = maps.within_limits.ravel()
                cols["in_workspace"] = maps.in_workspace.ravel()
                od.write_csv(f"sigma_ki_{name}.csv", cols)
        gr = record.gamma_range
        if gr is not None:
            if plots:
                plot_gamma_range(
                    od.path_for("gamma_range.png"),
                    gr.alpha,
                    gr.beta,
                    gr.gamma_min,
                    gr.gamma_max,
                    title=f"lee Fig. 2: $\\gamma_{{min}}$, $\\gamma_{{max}}$ ({gr.mode}), "
                    f"r = {geom.r:g}, $\\sigma_{{KI}}$ ≥ {gr.threshold:g}, legs within stroke",
                )
            if csv:
                A, B = np.meshgrid(gr.alpha, gr.beta, indexing="ij")
                d = gr.defined
                od.write_csv(
                    "gamma_range.csv",
                    {
                        "alpha_deg": _deg(A[d]),
                        "beta_deg": _deg(B[d]),
                        "n_gamma_in": gr.n_in[d],
                        "n_runs": gr.n_runs[d],
                        "gamma_min_deg": _deg(gr.gamma_min[d]),
                        "gamma_max_deg": _deg(gr.gamma_max[d]),
                    },
                )
                summary.setdefault("gamma_range", {})
                summary["gamma_range"] = dict(summary["gamma_range"])
                summary["gamma_range"]["csv_rows"] = int(d.sum())
                summary["gamma_range"]["rows_without_workspace"] = int((~d).sum())
        summary["files"] = [*od.files, "summary.json"]
        od.write_json("summary.json", summary)
        return od.files
