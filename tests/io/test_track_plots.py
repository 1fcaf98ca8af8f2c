"""Track plots and logs for any arm (issue 11 item 6) and the case overlays of park Figs. 5-8
(issue 17 item 4): what each figure shows, one layout engine, nothing outside the figure, each
figure drawn well under a second, the belt animated in the MCAP."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from matplotlib.layout_engine import ConstrainedLayoutEngine

from mechkin.io import track_out

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    from mechkin.api import run

    out = {}
    with pytest.MonkeyPatch.context() as mp:
        if "NUMBA_CACHE_DIR" not in os.environ:
            mp.setenv("NUMBA_CACHE_DIR", str(tmp_path_factory.mktemp("numba")))
        for name in ("puma560_track_line", "park_cases_overlay"):
            rep = run(ROOT / "scenarios" / f"{name}.yaml")
            assert rep.data is not None
            out[name] = rep.data
    return out


@pytest.mark.parametrize("name", ["puma560_track_line", "park_cases_overlay"])
def test_every_figure_constrained_and_unclipped(records, name, tmp_path) -> None:
    """Constrained layout, nothing drawn outside the figure, no empty panel (drawing time is a
    benchmark, `benchmarks/bench_track_plots.py`, never a timed assertion here)."""
    figs = track_out.figures(records[name])
    expected = {"phase.png", "hand_part.png", "path_3d.png", "joint_positions.png",
                "joint_velocities.png", "joint_accelerations.png", "joint_jerks.png",
                "torques.png"}
    if name == "park_cases_overlay":
        expected |= {"cases_phase.png", "cases_hand.png", "cases_joint_velocities.png",
                     "cases_torques.png"}
    assert set(figs) == expected
    for fname, fig in figs.items():
        assert isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine), fname
        fig.savefig(tmp_path / fname, dpi=110, format="png")
        box = fig.get_tightbbox(fig.canvas.get_renderer())  # every drawn artist, in inches
        w, h = fig.get_size_inches()
        assert box.x0 >= -0.01 and box.y0 >= -0.01, (fname, box)
        assert box.x1 <= w + 0.01 and box.y1 <= h + 0.01, (fname, box)
        assert all(ax.has_data() for ax in fig.axes), f"{fname}: an empty panel"


def test_path_3d_draws_the_hand_frames(records) -> None:
    """The triads are the hand frame's axes at N_TRIADS samples; their origins are the realised
    hand positions (forward kinematics of the plan = the path, to the path IK's tolerance)."""
    rec = records["puma560_track_line"]
    T = rec.hand_T
    assert T is not None and T.shape == (rec.trajectory.t.shape[0], 4, 4)
    np.testing.assert_allclose(T[:, :3, 3], rec.trajectory.hand, atol=1e-9)
    np.testing.assert_allclose(T[:, :3, :3] @ np.swapaxes(T[:, :3, :3], 1, 2),
                               np.broadcast_to(np.eye(3), (T.shape[0], 3, 3)), atol=1e-12)
    ax = track_out.path_3d_figure(rec).axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    x_axis = lines[f"hand x ({rec.hand_frame})"]
    xs, ys, zs = x_axis.get_data_3d()
    pts = np.column_stack([xs, ys, zs]).reshape(-1, 3, 3)  # (origin, tip, nan) per triad
    assert pts.shape[0] == track_out.N_TRIADS
    idx = np.unique(np.linspace(0, T.shape[0] - 1, track_out.N_TRIADS).round().astype(int))
    np.testing.assert_allclose(pts[:, 0], T[idx, :3, 3], atol=1e-12)
    d = pts[:, 1] - pts[:, 0]
    np.testing.assert_allclose(d / np.linalg.norm(d, axis=1)[:, None], T[idx, :3, 0],
                               atol=1e-12)
    assert {"hand line", "part", "arm at start", "arm at end", "hand y", "hand z"} <= set(lines)


def test_joint_positions_against_their_limits(records) -> None:
    rec = records["puma560_track_line"]
    fig = track_out.figures(rec)["joint_positions.png"]
    lo, hi = rec.limits["q"]
    for k, ax in enumerate(fig.axes):
        q = ax.get_lines()[0].get_ydata()
        np.testing.assert_array_equal(q, rec.trajectory.q[:, k])
        levels = sorted(float(ln.get_ydata()[0]) for ln in ax.get_lines()[1:])
        assert levels == [lo[k], hi[k]]


def test_phase_plane_has_the_limit_curve(records) -> None:
    rec = records["park_cases_overlay"]
    ax = track_out.phase_figure(rec).axes[0]
    curve = next(ln for ln in ax.get_lines() if ln.get_label().startswith("limit curve"))
    np.testing.assert_array_equal(curve.get_ydata(), rec.trajectory.rd_limit)
    # the plan never crosses the curve of its own torque and velocity limits
    assert np.all(rec.trajectory.rd <= rec.trajectory.rd_limit * (1 + 1e-9))


def test_case_overlays_one_line_per_case_with_a_legend(records) -> None:
    rec = records["park_cases_overlay"]
    names = [c.name for c in rec.cases]
    assert names == ["1: no limits", "2: torque", "3: all limits"]
    figs = track_out.case_figures(rec)
    phase = figs["cases_phase.png"].axes[0]
    labels = [t.get_text() for t in figs["cases_phase.png"].legends[0].get_texts()]
    assert all(any(lb.startswith(n) for lb in labels) for n in names)
    for c, ln in zip(rec.cases, [ln for ln in phase.get_lines()
                                 if not ln.get_label().endswith("limit curve")
                                 and ln.get_label().split(" (")[0] in names], strict=True):
        np.testing.assert_array_equal(ln.get_xdata(), c.trajectory.r)
    for fname, attr in (("cases_joint_velocities.png", "qd"), ("cases_torques.png", "torque")):
        fig = figs[fname]
        assert [t.get_text() for t in fig.legends[0].get_texts()] == names
        for k, ax in enumerate(fig.axes):
            data = [ln for ln in ax.get_lines() if ln.get_label() in names]
            assert len(data) == 3
            for c, ln in zip(rec.cases, data, strict=True):
                np.testing.assert_array_equal(ln.get_ydata(), getattr(c.trajectory, attr)[:, k])
    hand = figs["cases_hand.png"].axes[0]
    assert sum(ln.get_label().startswith("hand x") for ln in hand.get_lines()) == 3


def test_belt_stripes_move_with_the_belt() -> None:
    """Stripes advance |V_b| dt along the belt per sample (until they wrap at its end) and lie
    on the belt's top, below the part."""
    v = np.array([0.2, 0.0, 0.0])
    R = track_out._belt_frame(v)
    t = np.array([0.0, 0.1, 0.2])
    psize = np.array([0.08, 0.08, 0.04])
    centre = np.array([-0.5, 1.732, -0.05])
    seg = track_out._belt_stripes(t, v, R, centre, -1.0, 0.0, psize, -0.9)
    assert seg.shape == (3, 2 * track_out.BELT_STRIPES, 3)
    mid = 0.5 * (seg[:, 0::2] + seg[:, 1::2])  # (m, s, 3) stripe centres
    step = np.diff(mid[..., 0], axis=0)
    moved = np.isclose(step, 0.02, atol=1e-12)
    wrapped = np.isclose(step, 0.02 - 1.0, atol=1e-12)
    assert np.all(moved | wrapped) and np.sum(moved) >= seg.shape[1] // 2
    assert np.all((mid[..., 0] >= -1.0 - 1e-12) & (mid[..., 0] < 0.0))
    np.testing.assert_allclose(mid[..., 2], -0.05 + 0.0101, atol=1e-12)
    np.testing.assert_allclose(np.abs(seg[:, 1::2, 1] - seg[:, 0::2, 1]), 2 * psize[1])
