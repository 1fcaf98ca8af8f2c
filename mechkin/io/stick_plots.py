"""PNG stick drawings of mechanisms in 3-D: polylines, plates, frame triads, snapshots.

:class:`Stick`, :class:`Plate` and :class:`Triad` describe what is drawn;
:func:`stick_figure` lays out one 3-D panel per snapshot with a shared camera and
:func:`plot_stick_3d` saves it. Split out of ``plots.py`` (issue 23: modules that fit in a
head); every name stays importable from :mod:`mechkin.io.plots`.

Imports: numpy, matplotlib, mechkin.errors, io.plot_base.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from mechkin.errors import OutputError
from mechkin.io.plot_base import _PANEL_COLS, MAX_PANELS, _floats, _new_figure, _save


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


def _as_stick(item: np.ndarray | Stick, what: str) -> Stick:
    stick = item if isinstance(item, Stick) else Stick(points=np.asarray(item))
    pts = _floats(stick.points, what, 2)
    if pts.shape[1] != 3:
        raise OutputError(f"{what}: expected shape (p, 3), got {pts.shape}")
    return Stick(pts, stick.color, stick.linewidth, stick.linestyle, stick.marker, stick.label)


@dataclass(frozen=True, eq=False)
class Plate:
    """A filled polygon of a stick drawing (a Stewart base or moving plate, a platform).

    Parameters
    ----------
    points : array, shape (p, 3)
        Vertices in drawing order [m], p >= 3.
    color : str or tuple
        Face colour (drawn translucent, with a darker edge).
    label : str
        Legend entry (first panel only); empty for none.
    """

    points: np.ndarray
    color: str | tuple[float, ...] = "tab:orange"
    label: str = ""


@dataclass(frozen=True, eq=False)
class Triad:
    """A coordinate frame drawn as three axes (x red, y green, z blue).

    Parameters
    ----------
    T : array, shape (4, 4)
        Pose of the frame in the base frame [m].
    length : float or None
        Axis length [m]; None: 12 % of the drawing's extent.
    label : str
        Legend entry (first panel only), e.g. ``"target"``.
    style : str
        ``"-"`` solid (the mechanism's frame) or ``"--"`` dashed (a target).
    """

    T: np.ndarray
    length: float | None = None
    label: str = ""
    style: str = "-"


_TRIAD_RGB = ("tab:red", "tab:green", "tab:blue")


def _plane_square(point: np.ndarray, normal: np.ndarray, size: float) -> np.ndarray:
    """Corners (4, 3) of a square of side ``size`` centred at ``point``, normal ``normal``."""
    n = normal / np.linalg.norm(normal)
    helper = np.eye(3)[np.argmin(np.abs(n))]
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    h = 0.5 * size
    return point + h * np.array([u + v, -u + v, -u - v, u - v])


def _check_items(snapshots: Sequence[Sequence[Any]]) -> list[list[Any]]:
    out: list[list[Any]] = []
    for i, snap in enumerate(snapshots):
        row: list[Any] = []
        for j, it in enumerate(snap):
            what = f"snapshots[{i}][{j}]"
            if isinstance(it, Plate):
                pts = _floats(it.points, what, 2)
                if pts.shape[1] != 3 or pts.shape[0] < 3:
                    raise OutputError(f"{what}: expected plate vertices (p >= 3, 3), got "
                                      f"{pts.shape}")
                row.append(Plate(pts, it.color, it.label))
            elif isinstance(it, Triad):
                T = _floats(it.T, what, 2)
                if T.shape != (4, 4):
                    raise OutputError(f"{what}: expected a 4x4 pose, got {T.shape}")
                row.append(Triad(T, it.length, it.label, it.style))
            else:
                row.append(_as_stick(it, what))
        out.append(row)
    return out


def _item_points(it: Any) -> np.ndarray:
    if isinstance(it, Triad):
        return it.T[None, :3, 3]
    return it.points


def stick_figure(
    snapshots: Sequence[Sequence[np.ndarray | Stick | Plate | Triad]],
    title: str,
    labels: Sequence[str] | None = None,
    planes: Sequence[tuple[np.ndarray, np.ndarray, float]] | None = None,
    *,
    overlay: bool = False,
    view: tuple[float, float] = (25.0, -60.0),
    markers: Sequence[np.ndarray | None] | None = None,
    marker_label: str = "target",
) -> Figure:
    """The figure of :func:`plot_stick_3d` (not saved): mechanism configurations as 3-D stick
    figures, one panel each or overlaid.

    Like the stick drawings of mechanisms in papers (kim1995 Figs. 2, 4, 6), each panel is an
    orthographic view from ``view`` drawn on a plain 2-D axes: a ground grid at the lowest
    point (its spacing printed in the corner), the base axes x, y, z at the origin, plates as
    filled polygons (the farthest first), links, joint dots, frame triads and target crosses.
    All panels share the same bounds, so sizes compare across snapshots. Each panel is one
    line collection per style, one polygon collection and one scatter per marker style (no
    3-D axes, no artist per segment), so a figure costs about 0.1-0.3 s whatever the number
    of links.

    Parameters
    ----------
    snapshots : sequence of sequences of (array (p, 3), Stick, Plate or Triad)
        One entry per configuration; each is the list of items to draw: polylines (links,
        legs; an array is a plain polyline) [m], filled plates, coordinate triads. Up to 12
        panels (3 per row, 2 x 2 for four); any number when overlaid.
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
    Figure
        Constrained layout, on an Agg canvas.
    """
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.colors import to_rgba
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    n = len(snapshots)
    if n == 0:
        raise OutputError("snapshots: expected at least one configuration, got none")
    if not overlay and n > MAX_PANELS:
        raise OutputError(f"snapshots: expected at most {MAX_PANELS} panels, got {n} "
                          f"(use overlay=True)")
    if labels is not None and len(labels) != n:
        raise OutputError(f"labels: expected {n} labels, got {len(labels)}")
    items = _check_items(snapshots)
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
    every = ([_item_points(it) for snap in items for it in snap] + squares
             + [mk for mk in marks if mk is not None])
    pts = np.concatenate(every, axis=0) if every else np.zeros((1, 3))
    pts = pts[np.isfinite(pts).all(axis=1)]
    lo, hi = (pts.min(axis=0), pts.max(axis=0)) if len(pts) else (np.zeros(3), np.ones(3))
    extent = max(float((hi - lo).max()), 1e-3)
    cam = _Camera(*view)

    # the ground grid under everything: nice spacing over the drawing's x-y extent
    ticks = MaxNLocator(5).tick_values(float(lo[:2].min()), float(hi[:2].max()))
    step = float(ticks[1] - ticks[0]) if len(ticks) > 1 else extent
    gx = np.arange(np.floor(lo[0] / step), np.ceil(hi[0] / step) + 1) * step
    gy = np.arange(np.floor(lo[1] / step), np.ceil(hi[1] / step) + 1) * step
    z0 = float(lo[2])
    grid = ([np.array([[x, gy[0], z0], [x, gy[-1], z0]]) for x in gx]
            + [np.array([[gx[0], y, z0], [gx[-1], y, z0]]) for y in gy])
    L0 = 0.15 * extent
    base_axes = [np.array([[0.0, 0.0, 0.0], L0 * e]) for e in np.eye(3)]
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    view_pts = cam.xy(np.concatenate([corners, *grid, *base_axes]))
    xlo, ylo = view_pts.min(axis=0)
    xhi, yhi = view_pts.max(axis=0)
    pad = 0.04 * max(xhi - xlo, yhi - ylo)

    panels = 1 if overlay else n
    cols = 2 if panels == 4 else min(panels, _PANEL_COLS)  # 2x2, not 3 + 1 and 2 empty
    rows = math.ceil(panels / cols)
    aspect = (yhi - ylo + 2 * pad) / max(xhi - xlo + 2 * pad, 1e-12)
    w = 3.9
    fig = _new_figure((w * cols + 0.2, min(max(w * aspect, 2.2), 5.0) * rows + 0.9))
    fig.suptitle(title)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    for ax in axes[panels:]:
        fig.delaxes(ax)  # (a 3-column grid with fewer snapshots than cells: no empty panels)
    axes = list(axes[:panels])
    handles: dict[str, Any] = {}

    def handle(label: str, h: Any) -> None:
        if label and label not in handles:
            handles[label] = h

    for ax in axes:
        ax.add_collection(LineCollection([cam.xy(g) for g in grid], colors="0.85",
                                         linewidths=0.6, zorder=0))
        ax.add_collection(LineCollection([cam.xy(g) for g in base_axes], colors=_TRIAD_RGB,
                                         linewidths=1.0, zorder=0.5))
        for k, name in enumerate("xyz"):
            x, y = cam.xy(base_axes[k][1:])[0]
            ax.text(x, y, name, fontsize="x-small", color=_TRIAD_RGB[k], ha="center",
                    va="center", zorder=0.5)
        if squares:
            ax.add_collection(PolyCollection([cam.xy(sq) for sq in squares],
                                             facecolors=(0.5, 0.6, 0.8, 0.25),
                                             edgecolors=(0.3, 0.3, 0.5, 0.6), zorder=0.8))
        ax.set_xlim(xlo - pad, xhi + pad)
        ax.set_ylim(ylo - pad, yhi + pad)
        ax.set_aspect("equal")
        ax.set_xticks([])  # no tick machinery behind the hidden axes (half the time otherwise)
        ax.set_yticks([])
        ax.set_axis_off()
        ax.text(0.0, 0.0, f"grid {step:g} m", transform=ax.transAxes, fontsize="x-small",
                color="0.45", ha="left", va="bottom")

    for i, snap in enumerate(items):
        ax = axes[0 if overlay else i]
        alpha = 0.35 + 0.65 * (i + 1) / n if overlay else 1.0
        snap_label = labels[i] if overlay and labels is not None else ""
        # links: one collection per (colour, width, style); vertices: one scatter per colour
        groups: dict[tuple, list[np.ndarray]] = {}
        verts: dict[tuple, list[np.ndarray]] = {}
        polys: list[tuple[float, np.ndarray, Any]] = []
        triads: dict[str, tuple[list[np.ndarray], list[str]]] = {}
        for j, it in enumerate(snap):
            if isinstance(it, Plate):
                polys.append((float(cam.depth(it.points).mean()), cam.xy(it.points), it.color))
                handle(it.label, Patch(facecolor=to_rgba(it.color, 0.45), edgecolor="0.25"))
                continue
            if isinstance(it, Triad):
                L = it.length if it.length is not None else 0.12 * extent
                o = it.T[:3, 3]
                segs, cs = triads.setdefault(it.style, ([], []))
                for k in range(3):
                    segs.append(cam.xy(np.stack([o, o + L * it.T[:3, k]])))
                    cs.append(_TRIAD_RGB[k])
                handle(it.label, Line2D([], [], color="0.2", linestyle=it.style, linewidth=1.5))
                continue
            color = it.color if it.color is not None else f"C{(i if overlay else j) % 10}"
            P = cam.xy(it.points)
            groups.setdefault((color, it.linewidth, it.linestyle), []).extend(
                np.stack([P[:-1], P[1:]], axis=1))
            if it.marker:
                verts.setdefault((color, it.marker), []).append(P)
            handle(snap_label if (snap_label and j == 0) else it.label,
                   Line2D([], [], color=color, linewidth=it.linewidth, linestyle=it.linestyle,
                          marker=it.marker or "", markersize=3.5, alpha=alpha))
        if polys:  # painter's order: the farthest plate first
            polys.sort(key=lambda t: t[0])
            ax.add_collection(PolyCollection(
                [t[1] for t in polys], facecolors=[to_rgba(t[2], 0.45 * alpha) for t in polys],
                edgecolors=[to_rgba("0.25", 0.9 * alpha)] * len(polys), linewidths=1.0,
                zorder=1))
        for (color, lw, ls), segs in groups.items():
            ax.add_collection(LineCollection(segs, colors=color, linewidths=lw, linestyles=ls,
                                             alpha=alpha, zorder=2, capstyle="round"))
        for (color, mk), Ps in verts.items():
            V = np.concatenate(Ps)
            ax.scatter(V[:, 0], V[:, 1], marker=mk, s=10, color=color, alpha=alpha, zorder=3,
                       linewidths=0)
        for style, (segs, cs) in triads.items():
            ax.add_collection(LineCollection(segs, colors=cs, linewidths=1.6, linestyles=style,
                                             zorder=4))
        if marks[i] is not None:
            mk = cam.xy(marks[i])
            ax.scatter(mk[:, 0], mk[:, 1], marker="x", s=40, color="tab:red", zorder=5)
            handle(marker_label, Line2D([], [], color="tab:red", marker="x", linestyle="",
                                        markersize=7))
        if labels is not None and not overlay:
            ax.set_title(labels[i], fontsize="medium")
    if handles:
        # one legend for the figure, below the panels (never over a drawing)
        fig.legend(list(handles.values()), list(handles), loc="outside lower center",
                   ncols=min(len(handles), 4 if cols > 1 else 2), fontsize="small")
    return fig


def plot_stick_3d(
    path: str | os.PathLike[str],
    snapshots: Sequence[Sequence[np.ndarray | Stick | Plate | Triad]],
    title: str,
    labels: Sequence[str] | None = None,
    planes: Sequence[tuple[np.ndarray, np.ndarray, float]] | None = None,
    *,
    overlay: bool = False,
    view: tuple[float, float] = (25.0, -60.0),
    markers: Sequence[np.ndarray | None] | None = None,
    marker_label: str = "target",
) -> Path:
    """Save :func:`stick_figure` as the PNG ``path`` and return ``path``.

    Examples
    --------
    >>> legs = [np.array([[0, 0, 0], [0.1, 0, 0.5]]), np.array([[0.2, 0, 0], [0.1, 0, 0.5]])]
    >>> plot_stick_3d(out / "poses.png", [legs], "Stewart platform")  # doctest: +SKIP
    """
    return _save(stick_figure(snapshots, title, labels, planes, overlay=overlay, view=view,
                              markers=markers, marker_label=marker_label), path)


class _Camera:
    """Orthographic view from elevation ``elev`` and azimuth ``azim`` [deg] (the convention of
    matplotlib's 3-D ``view_init``): screen x, screen y and depth (towards the viewer)."""

    def __init__(self, elev: float, azim: float) -> None:
        e, a = np.deg2rad(elev), np.deg2rad(azim)
        self.eye = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        self.right = np.array([-np.sin(a), np.cos(a), 0.0])
        self.up = np.cross(self.eye, self.right)

    def xy(self, P: np.ndarray) -> np.ndarray:
        """Screen coordinates (k, 2) of points (k, 3) [m]."""
        return np.asarray(P, dtype=float) @ np.stack([self.right, self.up], axis=1)

    def depth(self, P: np.ndarray) -> np.ndarray:
        return np.asarray(P, dtype=float) @ self.eye
