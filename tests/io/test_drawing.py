"""Stick drawings like the papers' figures (issue 17 item 6, issue 16 item 5).

Geometry (mechkin.model.drawing): links are segments joint to joint (each end a joint point or
a frame origin of one rigid body, never a spoke from the base origin), declared plates are
polygons through the named frames and joints, the convex hull stands in when nothing is
declared, and bad ``drawing:`` input is a located ConfigError. Figures: the promised legends,
no empty panels and no text outside the figure (checked with the Agg renderer after layout).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.text import Text

from mechkin.errors import ConfigError, OutputError
from mechkin.io.plots import Plate, Stick, Triad, plot_stick_3d, stick_figure
from mechkin.model import load_mechanism
from mechkin.model.drawing import plate_polygons, skeleton_segments, stick_drawing
from mechkin.model.kinematics import forward_kinematics

ROOT = Path(__file__).resolve().parents[2]
MECH = ROOT / "mechanisms"


def _home(mech) -> np.ndarray:
    return np.where(np.isfinite(mech.home), mech.home, 0.0)


def _random_q(mech, m: int, seed: int = 7) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(mech.lower), mech.lower, -np.pi)
    hi = np.where(np.isfinite(mech.upper), mech.upper, np.pi)
    return lo + (hi - lo) * rng.random((m, mech.n))


def _candidates(mech, kin) -> np.ndarray:
    """Every joint point and frame origin (m, k, 3)."""
    return np.concatenate([kin.axes()[1], kin.frames(mech)[..., :3, 3]], axis=1)


def _group_point(mech, kin, name: str) -> np.ndarray:
    g = next(g for g in mech.groups if g.name == name)
    return kin.axes()[1][:, g.joints[0]]


# --------------------------------------------------------------------------- segments


@pytest.mark.parametrize("name", ["puma560", "panda", "kim1995_direct_drive", "kim1995_stewart",
                                  "delta", "five_bar", "kim1995_end_effector_robot"])
def test_every_segment_end_is_a_joint_point_or_frame_origin(name):
    mech = load_mechanism(MECH / f"{name}.yaml")
    kin = forward_kinematics(mech, np.vstack([_home(mech), _random_q(mech, 4)]))
    d = stick_drawing(mech, kin)
    assert d.segments.shape[1] > 0
    cand = _candidates(mech, kin)
    centroids = [p.mean(axis=1) for p in d.plates.values()]
    if centroids:
        cand = np.concatenate([cand, np.stack(centroids, axis=1)], axis=1)
    ends = d.segments.reshape(kin.q.shape[0], -1, 3)
    dist = np.linalg.norm(ends[:, :, None, :] - cand[:, None, :, :], axis=-1).min(axis=2)
    assert dist.max() < 1e-9, f"{name}: a segment end is neither a joint point nor a frame"


@pytest.mark.parametrize("name", ["puma560", "panda", "kim1995_direct_drive"])
def test_segments_are_rigid_links_on_revolute_chains(name):
    """Joint to joint along the tree: both ends of a segment sit on one rigid body, so on an
    all-revolute mechanism every segment keeps its length in every configuration (a spoke
    from the base to a distal frame would not)."""
    mech = load_mechanism(MECH / f"{name}.yaml")
    assert (mech.s == 0).all()
    seg = stick_drawing(mech, forward_kinematics(mech, _random_q(mech, 6, seed=3))).segments
    length = np.linalg.norm(seg[:, :, 1] - seg[:, :, 0], axis=-1)
    np.testing.assert_allclose(length, np.broadcast_to(length[:1], length.shape), atol=1e-12)


def test_stewart_legs_run_joint_to_joint_without_spokes():
    """kim1995 Fig. 4: six legs from A_i (universal joints) to B_j (plate joints), the plates
    as polygons; no segment from the base origin, which no joint occupies."""
    mech = load_mechanism(MECH / "kim1995_stewart.yaml")
    kin = forward_kinematics(mech, mech.home[None])
    seg = stick_drawing(mech, kin).segments[0]
    assert seg.shape[0] == 6
    A = np.stack([_group_point(mech, kin, f"u{i}")[0] for i in range(1, 7)])
    B = kin.frames(mech, [mech.frame_index(f"b{k}") for k in (1, 1, 2, 2, 3, 3)])[0, :, :3, 3]
    want = np.hstack([A, B])  # leg i: A_i -> B at its end (home closes the loops to ~1e-5 m)
    got = seg.reshape(-1, 6)
    err = np.linalg.norm(got[:, None, :] - want[None, :, :], axis=-1)
    assert sorted(err.argmin(axis=1).tolist()) == list(range(6))
    assert err.min(axis=1).max() < 1e-4
    assert np.linalg.norm(seg, axis=-1).min() > 1.0  # nothing at the base origin


def test_skeleton_bounds_every_frame_distance():
    """skeleton_segments (links and plate outlines) bound the distance of every frame from the
    base by their summed length at home (ik's reach test relies on it)."""
    for name in ("puma560", "panda", "ur5"):
        mech = load_mechanism(MECH / f"{name}.yaml")
        seg = skeleton_segments(mech, forward_kinematics(mech, _home(mech)[None]))[0]
        bound = float(np.linalg.norm(seg[:, 1] - seg[:, 0], axis=-1).sum())
        kin = forward_kinematics(mech, _random_q(mech, 200, seed=11))
        far = float(np.linalg.norm(kin.frames(mech)[..., :3, 3], axis=-1).max())
        assert far <= bound + 1e-12, name


# --------------------------------------------------------------------------- plates


def test_declared_plates_pass_through_the_named_frames_and_joints():
    mech = load_mechanism(MECH / "kim1995_stewart.yaml")
    kin = forward_kinematics(mech, mech.home[None])
    plates = plate_polygons(mech, kin)
    assert list(plates) == ["base_plate", "moving_plate"]
    base = np.stack([_group_point(mech, kin, f"u{i}")[0] for i in (1, 6, 5, 4, 3, 2)])
    np.testing.assert_allclose(plates["base_plate"][0], base, atol=1e-12)
    top = kin.frames(mech, [mech.frame_index(f"b{k}") for k in (1, 2, 3)])[0, :, :3, 3]
    np.testing.assert_allclose(plates["moving_plate"][0], top, atol=1e-12)


def _stewart_text(drawing: str | None) -> str:
    text = (MECH / "kim1995_stewart.yaml").read_text()
    start = text.index("drawing:")
    end = text.index("independent:", start)
    return text[:start] + (drawing or "") + text[end:]


def _write(tmp_path: Path, text: str, name: str = "m.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _is_convex_polygon(P: np.ndarray) -> bool:
    c = P - P.mean(axis=0)
    n = np.linalg.svd(c)[2][2]
    cross = [float(np.cross(P[(i + 1) % len(P)] - P[i], P[(i + 2) % len(P)] - P[(i + 1) % len(P)])
                   @ n) for i in range(len(P))]
    return all(x > 0 for x in cross) or all(x < 0 for x in cross)


def test_convex_hull_when_nothing_is_declared(tmp_path):
    mech = load_mechanism(_write(tmp_path, _stewart_text(None)))
    kin = forward_kinematics(mech, mech.home[None])
    plates = plate_polygons(mech, kin)
    assert set(plates) == {"base", "plate"}  # named after their links
    A = {tuple(np.round(_group_point(mech, kin, f"u{i}")[0], 9)) for i in range(1, 7)}
    assert {tuple(p) for p in np.round(plates["base"][0], 9)} == A
    assert _is_convex_polygon(plates["base"][0])
    B = kin.frames(mech, [mech.frame_index(f"b{k}") for k in (1, 2, 3)])[0, :, :3, 3]
    assert {tuple(p) for p in np.round(plates["plate"][0], 9)} == {tuple(p) for p in
                                                                   np.round(B, 9)}
    # the same legs as with the declared plates
    declared = load_mechanism(MECH / "kim1995_stewart.yaml")
    np.testing.assert_allclose(stick_drawing(mech, kin).segments,
                               stick_drawing(declared, kin).segments, atol=1e-12)


def test_declared_plate_wins_and_auto_plates_off(tmp_path):
    only_top = "drawing:\n  plates:\n    - {name: top, frames: [b1, b3, b2]}\n"
    mech = load_mechanism(_write(tmp_path, _stewart_text(only_top)))
    kin = forward_kinematics(mech, mech.home[None])
    plates = plate_polygons(mech, kin)
    assert list(plates) == ["top", "base"]  # declared, then the hull of the base
    off = "drawing:\n  auto_plates: false\n  plates:\n    - {name: top, frames: [b1, b3, b2]}\n"
    mech = load_mechanism(_write(tmp_path, _stewart_text(off), "off.yaml"))
    assert list(plate_polygons(mech, kin)) == ["top"]


def test_open_chains_get_no_plates():
    for name in ("puma560", "panda", "kim1995_direct_drive"):
        mech = load_mechanism(MECH / f"{name}.yaml")
        assert plate_polygons(mech, forward_kinematics(mech, _home(mech)[None])) == {}, name


LINE = r"^{path}:(\d+): {key}: {msg}"


@pytest.mark.parametrize("block, key, msg", [
    ("drawing:\n  plates:\n    - {name: top, frames: [b1, b2, nope]}\n",
     r"drawing\.plates\[0\]\.frames\[2\]", r"unknown frame or joint 'nope'"),
    ("drawing:\n  plates:\n    - {name: top, frames: [b1, b2]}\n",
     r"drawing\.plates\[0\]\.frames", r".*at least 3"),
    ("drawing:\n  plates:\n    - {name: top, frames: [b1, b2, b1]}\n",
     r"drawing\.plates\[0\]\.frames\[2\]", r"'b1' is listed twice"),
    ("drawing:\n  plates:\n    - {name: mixed, frames: [b1, b2, u1]}\n",
     r"drawing\.plates\[0\]\.frames", r"the points of a plate must be fixed on one link"),
    ("drawing:\n  plates:\n    - {name: a, frames: [b1, b2, b3]}\n"
     "    - {name: a, frames: [b1, b3, b2]}\n",
     r"drawing\.plates\[1\]\.name", r"duplicate plate 'a'"),
    ("drawing:\n  plates: 3\n", r"drawing\.plates", r".*list"),
    ("drawing:\n  plate: []\n", r"drawing\.plate", r".*"),
])
def test_bad_drawing_is_a_located_config_error(tmp_path, block, key, msg):
    path = _write(tmp_path, _stewart_text(block))
    with pytest.raises(ConfigError) as exc:
        load_mechanism(path)
    text = str(exc.value)
    assert len(text.splitlines()) == 1, text
    m = re.match(LINE.format(path=re.escape(str(path)), key=key, msg=msg), text)
    assert m, text
    # the line is the one the key is written on (or its list entry)
    lines = path.read_text().splitlines()
    assert "drawing" in "\n".join(lines[: int(m.group(1))])
    assert int(m.group(1)) >= lines.index("drawing:") + 1


def test_collinear_plate_is_refused(tmp_path):
    text = (
        "name: line\nlinks:\n  - name: base\n    frames:\n"
        "      - {name: a, xyz: [0, 0, 0.1]}\n      - {name: b, xyz: [1, 0, 0.1]}\n"
        "      - {name: c, xyz: [2, 0, 0.1]}\n  - name: arm\n"
        "joints:\n  - {name: q1, type: revolute, parent: base, child: arm, axis: [0, 0, 1]}\n"
        "drawing:\n  plates:\n    - {name: bar, frames: [a, b, c]}\n"
    )
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError, match=r":13: drawing\.plates\[0\]\.frames: the points "
                                          r"lie on one line"):
        load_mechanism(path)


# --------------------------------------------------------------------------- figures


def _texts_outside(fig: Figure) -> list[str]:
    """Texts drawn by the Agg renderer (after layout) whose extent leaves the figure. Only
    texts actually drawn count: tick labels beyond the view limits exist but are not drawn."""
    drawn: list[tuple[Text, Any]] = []
    original = Text.draw

    def spy(self: Text, renderer: Any) -> None:
        original(self, renderer)
        if self.get_visible() and self.get_text().strip():
            drawn.append((self, self.get_window_extent(renderer)))

    Text.draw = spy  # type: ignore[method-assign]
    try:
        fig.canvas.draw()
    finally:
        Text.draw = original  # type: ignore[method-assign]
    assert drawn, "no text drawn at all"
    box = fig.bbox
    return [f"{t.get_text()!r} at {e}" for t, e in drawn
            if e.x0 < box.x0 - 1 or e.y0 < box.y0 - 1 or e.x1 > box.x1 + 1
            or e.y1 > box.y1 + 1]


def _legend_texts(fig: Figure) -> list[str]:
    legends = [ax.get_legend() for ax in fig.axes] + list(fig.legends)
    return [t.get_text() for lg in legends if lg is not None for t in lg.get_texts()]


def _empty_axes(fig: Figure) -> list[int]:
    return [i for i, ax in enumerate(fig.axes)
            if not (ax.lines or ax.collections or ax.patches or ax.images)
            and ax.get_label() != "<colorbar>"]


@pytest.fixture
def figures(monkeypatch) -> dict[str, dict[str, Any]]:
    """PNG name -> {legend, outside, empty} of every figure saved while the test runs; the
    figure is laid out and drawn by the Agg renderer, nothing is written."""
    seen: dict[str, dict[str, Any]] = {}

    def record(fig: Figure, fname: Any, *args: Any, **kwargs: Any) -> None:
        name = Path(fname).name
        m = re.match(r"^\.(.+)\.[0-9a-f]+\.part\.png$", name)  # atomic_path temp names
        seen[m.group(1) if m else name] = {
            "legend": _legend_texts(fig), "outside": _texts_outside(fig),
            "empty": _empty_axes(fig)}
        Path(fname).write_bytes(b"")

    monkeypatch.setattr(Figure, "savefig", record)
    return seen


def _run(name: str):
    from mechkin.api import run

    return run(ROOT / "scenarios" / f"{name}.yaml")


class _Od:
    def __init__(self, root: Path) -> None:
        self.root = root

    def path_for(self, name: str) -> Path:
        return self.root / name


def test_fk_figures_of_the_stewart_platform(figures, tmp_path):
    from mechkin.io.motion_out import write_plots

    write_plots(_Od(tmp_path), _run("kim1995_stewart_fk").data)
    stick = figures["stick.png"]
    assert {"base_plate", "moving_plate", "links", "end effector (x, y, z)"} <= set(
        stick["legend"])
    for name, info in figures.items():
        assert not info["outside"], f"{name}: {info['outside']}"
        assert not info["empty"], f"{name}: empty panels {info['empty']}"


def test_fk_joint_legend_and_ik_figures(figures, tmp_path):
    from mechkin.io.motion_out import write_plots

    fk = _run("kim1995_direct_drive_fk").data
    (tmp_path / "fk").mkdir()
    write_plots(_Od(tmp_path / "fk"), fk)
    assert figures["joints.png"]["legend"] == [f"{n} [rad]" for n in fk.joint_names]
    assert "links" in figures["stick.png"]["legend"]
    checked = dict(figures)
    figures.clear()
    ik = _run("kim1995_table3_direct_drive_ik").data
    (tmp_path / "ik").mkdir()
    write_plots(_Od(tmp_path / "ik"), ik)
    assert {"links", "target", "end effector (x, y, z)"} <= set(figures["stick.png"]["legend"])
    assert figures["convergence.png"]["legend"]
    assert figures["joints.png"]["legend"]
    checked.update({f"ik/{k}": v for k, v in figures.items()})
    for name, info in checked.items():
        assert not info["outside"], f"{name}: {info['outside']}"
        assert not info["empty"], f"{name}: empty panels {info['empty']}"


def test_stick_panels_are_thinned_and_never_empty():
    from mechkin.io.motion_out import MAX_STICK_PANELS, stick_snapshots
    from mechkin.records import MotionRecord

    rec = MotionRecord(task="ik", title="t", mechanism="m", times=np.arange(9.0),
                       q=np.zeros((9, 1)), joint_names=["q"], joint_units=["rad"], columns={},
                       snapshots=list(range(9)))
    snaps = stick_snapshots(rec)
    assert len(snaps) == MAX_STICK_PANELS and snaps[0] == 0 and snaps[-1] == 8
    for k in (1, 2, 3, 5, 7):
        items = [[Stick(np.array([[0, 0, 0], [1, 0, float(i)]]))] for i in range(k)]
        fig = stick_figure(items, "t", labels=[f"#{i}" for i in range(k)])
        assert len(fig.axes) == k and not _empty_axes(fig)
        assert not _texts_outside(fig)


def test_workspace_figures_keep_their_text_inside(figures, tmp_path):
    from mechkin.io.workspace_plots import plot_gamma_range, plot_isotropy_maps, plot_point_cloud

    a = np.deg2rad(np.linspace(-40, 40, 21))
    b = np.deg2rad(np.linspace(-40, 40, 17))
    A, B = np.meshgrid(a, b, indexing="ij")
    sigma = np.stack([np.clip(1 - (A**2 + B**2) * g, 0, 1) for g in (1.0, 2.0, 3.0)])
    plot_isotropy_maps(tmp_path / "iso.png", a, b, np.deg2rad([0, 30, 60]), sigma,
                       sigma > 0.05, title="lee Fig. 4 (synthetic)")
    plot_gamma_range(tmp_path / "gr.png", a, b, -0.5 - A**2, 0.5 + B**2, title="lee Fig. 2")
    rng = np.random.default_rng(0)
    P = rng.normal(size=(6000, 3))
    plot_point_cloud(tmp_path / "cloud.png", P, rng.random(6000), None, title="cloud")
    assert set(figures) == {"iso.png", "gr.png", "cloud.png"}
    for name, info in figures.items():
        assert not info["outside"], f"{name}: {info['outside']}"
        assert not info["empty"], f"{name}: empty panels {info['empty']}"


def test_plate_and_triad_items(tmp_path):
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    fig = stick_figure([[Plate(tri, label="plate"), Triad(np.eye(4), label="frame"),
                         Stick(tri[:2], label="link")]], "t", markers=[np.array([0.5, 0.5, 0])])
    assert _legend_texts(fig) == ["plate", "frame", "link", "target"]
    with pytest.raises(OutputError, match=r"snapshots\[0\]\[0\]: expected plate vertices"):
        plot_stick_3d(tmp_path / "x.png", [[Plate(tri[:2])]], "t")
    with pytest.raises(OutputError, match=r"snapshots\[0\]\[0\]: expected a 4x4 pose"):
        plot_stick_3d(tmp_path / "x.png", [[Triad(np.eye(3))]], "t")


def test_the_text_check_sees_a_clipped_label():
    """The check above has teeth: a label pushed past the right edge is reported."""
    fig = Figure(figsize=(3, 2), layout="constrained")
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1])
    fig.text(0.98, 0.5, "a label that does not fit")
    assert any("does not fit" in t for t in _texts_outside(fig))
