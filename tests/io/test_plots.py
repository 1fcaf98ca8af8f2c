"""Plots: non-empty PNGs written atomically, generic array inputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.errors import OutputError
from mechkin.io.plots import Stick, plot_convergence, plot_series, plot_stick_3d

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _is_png(path: Path) -> bool:
    data = path.read_bytes()
    return data.startswith(PNG_MAGIC) and len(data) > 2000


def test_plot_series(tmp_path: Path) -> None:
    t = np.linspace(0.0, 2.0, 50)
    q = np.stack([np.sin(t), np.cos(t)], axis=1)
    q[10, 0] = np.nan  # a gap, not an error
    path = plot_series(tmp_path / "q.png", t, q, ["q1 [rad]", "q2 [rad]"], "t [s]", "q [rad]",
                       "Joint trajectories", limits=[-1.0, 1.0])
    assert _is_png(path)
    assert [p.name for p in tmp_path.iterdir()] == ["q.png"]


def test_plot_series_without_labels(tmp_path: Path) -> None:
    t = np.linspace(0.0, 1.0, 5)
    path = plot_series(tmp_path / "q.png", t, np.zeros((5, 2)), ["", ""], "t [s]", "q", "q")
    assert _is_png(path)


def test_plot_series_shape_errors(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="labels"):
        plot_series(tmp_path / "q.png", np.arange(3.0), np.zeros((3, 2)), ["a"], "x", "y", "t")
    with pytest.raises(OutputError, match=r"ys: expected shape \(4, k\)"):
        plot_series(tmp_path / "q.png", np.arange(4.0), np.zeros((3, 1)), ["a"], "x", "y", "t")
    assert list(tmp_path.iterdir()) == []


def _legs(phase: float) -> list[np.ndarray | Stick]:
    base = np.array([[np.cos(a), np.sin(a), 0.0] for a in np.linspace(0, 2 * np.pi, 7)])
    top = 0.5 * base + [0.05 * np.sin(phase), 0.0, 0.8]
    legs = [np.stack([base[i], top[(i + 1) % 6]]) for i in range(6)]
    return [Stick(base, color="k", marker="", label="base"),
            Stick(top, color="tab:red", linewidth=3, label="platform"), *legs]


def test_plot_stick_3d_panels_and_planes(tmp_path: Path) -> None:
    snaps = [_legs(p) for p in np.linspace(0, np.pi, 4)]
    path = plot_stick_3d(tmp_path / "poses.png", snaps, "Stewart platform",
                         labels=[f"t = {k} s" for k in range(4)],
                         planes=[(np.zeros(3), np.array([0.0, 0.3, 1.0]), 1.5)])
    assert _is_png(path)


def test_plot_stick_3d_overlay(tmp_path: Path) -> None:
    snaps = [[np.array([[0, 0, 0], [0.3 * np.cos(a), 0.3 * np.sin(a), 0.2]])] for a in range(8)]
    assert _is_png(plot_stick_3d(tmp_path / "o.png", snaps, "Overlay", overlay=True,
                                 labels=[str(a) for a in range(8)]))


def test_plot_stick_3d_errors(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match=r"snapshots\[0\]\[0\]: expected shape \(p, 3\)"):
        plot_stick_3d(tmp_path / "s.png", [[np.zeros((3, 2))]], "x")
    with pytest.raises(OutputError, match="at most"):
        plot_stick_3d(tmp_path / "s.png", [[np.zeros((2, 3))]] * 13, "x")
    with pytest.raises(OutputError, match=r"\.png"):
        plot_stick_3d(tmp_path / "s.jpg", [[np.zeros((2, 3))]], "x")
    assert list(tmp_path.iterdir()) == []


def test_plot_convergence(tmp_path: Path) -> None:
    f_cg = 10.0 ** -np.arange(12.0)
    f_lm = np.r_[1.0, 1e-3, 1e-9, 0.0]  # exact zero is masked on a log axis
    path = plot_convergence(tmp_path / "f.png", {"CG": f_cg, "LM": f_lm}, "f [m^2]")
    assert _is_png(path)
    assert _is_png(plot_convergence(tmp_path / "g.png", {"x": [3.0, 2.0, 2.5]}, "x", logy=False))
