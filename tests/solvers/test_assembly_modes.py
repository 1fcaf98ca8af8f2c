"""``fk: {assembly: all}``: every assembly mode of the loop closure (mechkin.solvers.assembly).

Cross-checks: the four-bar's two modes against the two intersections of the coupler and rocker
circles; lee's spherical mechanism against the complete forward position of
:func:`mechkin.solvers.closed_form.lee_spherical.forward_position` (count and plate
orientations); the fk task's summary.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mechkin.model import load_mechanism
from mechkin.model.kinematics import closure_residual, forward_kinematics
from mechkin.solvers.assembly import assembly_modes, mode_of
from mechkin.solvers.closed_form.lee_spherical import forward_position, inverse_position
from mechkin.solvers.closed_form.recognise import check_closed_form

ROOT = Path(__file__).resolve().parents[2]
FOURBAR = ROOT / "tests" / "data" / "fourbar.yaml"
LEE = ROOT / "mechanisms" / "lee_spherical_rrps.yaml"


def circle_intersections(c1, r1, c2, r2):
    d = np.linalg.norm(c2 - c1)
    a = (r1**2 - r2**2 + d**2) / (2 * d)
    h = np.sqrt(r1**2 - a**2)
    u = (c2 - c1) / d
    m = c1 + a * u
    n = np.array([-u[1], u[0]])
    return np.array([m + h * n, m - h * n])


@pytest.mark.parametrize("crank_deg", [60.0, 100.0, -30.0])
def test_fourbar_open_and_crossed(crank_deg):
    mech = load_mechanism(FOURBAR)
    qv = np.radians([crank_deg])
    modes = assembly_modes(mech, qv, starts=64)
    assert modes.count == 2
    kin = forward_kinematics(mech, modes.q)
    assert np.abs(closure_residual(mech, kin)).max() < 1e-9
    e = kin.frames(mech, [mech.end_effector])[:, 0, :2, 3]
    ref = circle_intersections(0.3 * np.array([np.cos(qv[0]), np.sin(qv[0])]), 1.0,
                               np.array([1.0, 0.0]), 0.8)
    d = np.linalg.norm(e[:, None] - ref[None], axis=-1)
    assert d.min(axis=1).max() < 1e-9 and d.min(axis=0).max() < 1e-9
    # the guess's mode first, distances non-decreasing, revolute joints near the guess
    assert np.all(np.diff(modes.distance) >= 0)
    assert np.all(np.abs(modes.q[:, mech.dependent] - mech.home[mech.dependent]) <= np.pi)


def _lee_lengths(min_modes: int) -> np.ndarray:
    geom = check_closed_form(load_mechanism(LEE), "lee_spherical").geometry
    rng = np.random.default_rng(0)
    for _ in range(2000):
        mu = rng.uniform(-0.6, 0.6, 3)
        mu[2] += 0.5
        lengths = np.asarray(inverse_position(geom, mu)).reshape(3)
        if forward_position(geom, lengths).n_modes >= min_modes:
            return lengths
    raise AssertionError("no leg lengths with that many modes")


@pytest.mark.parametrize("min_modes", [2, 4])
def test_lee_modes_match_the_forward_position(min_modes):
    mech = load_mechanism(LEE)
    geom = check_closed_form(mech, "lee_spherical").geometry
    lengths = _lee_lengths(min_modes)
    ref = forward_position(geom, lengths)
    assert ref.n_modes >= min_modes
    modes = assembly_modes(mech, lengths, starts=256)
    assert modes.count == ref.n_modes
    kin = forward_kinematics(mech, modes.q)
    assert np.abs(closure_residual(mech, kin)).max() < 1e-9
    R = kin.frames(mech, [mech.end_effector])[:, 0, :3, :3]
    d = np.linalg.norm(R[:, None] - ref.R[None], axis=(-2, -1))
    assert d.min(axis=1).max() < 1e-7 and d.min(axis=0).max() < 1e-7
    assert np.allclose(modes.q[:, mech.independent], lengths)


def test_mode_of_finds_the_motion_mode():
    mech = load_mechanism(FOURBAR)
    modes = assembly_modes(mech, mech.home[mech.independent], starts=32)
    for k in range(modes.count):
        assert mode_of(mech, modes, modes.q[k]) == k


def _scenario(tmp: Path, extra: str) -> Path:
    p = tmp / "fk.yaml"
    p.write_text(f"""name: fourbar_modes
task: fk
mechanism: {FOURBAR}
units: {{length: m, angle: deg}}
fk:
  time: {{start: 0, stop: 1, step: 0.1}}
  motion:
    q_crank: {{type: ramp, from: 60, to: 90}}
{extra}outputs: {{csv: false, plots: false, mcap: false}}
""")
    return p


def test_fk_task_assembly_all(tmp_path):
    from mechkin.api import run

    rep = run(_scenario(tmp_path, "  assembly: all\n  assembly_at: [{q_crank: 100}]\n"))
    s = rep.summary
    assert rep.status == "ok"
    assert s["n_assembly_modes"] == 2 == len(s["assembly_modes"])
    assert s["n_assembly_modes_within_limits"] == 2
    assert s["assembly_mode_followed"] == 0  # the initial guess's mode, nearest first
    for m in s["assembly_modes"]:
        assert m["residual"] < 1e-9
    # the motion's first step is the followed mode
    first = s["assembly_modes"][0]["q"]
    assert s["assembly_at"][0]["n_assembly_modes"] == 2
    assert abs(s["assembly_at"][0]["q_v"]["q_crank"] - np.radians(100)) < 1e-12
    assert set(first) == {"q_crank", "q_coupler", "q_rocker"}
    rep1 = run(_scenario(tmp_path, ""))
    assert "assembly_modes" not in rep1.summary


def test_fk_task_assembly_bad_joint(tmp_path):
    from mechkin.api import run
    from mechkin.errors import ConfigError

    with pytest.raises(ConfigError,
                       match=r"fk.yaml:\d+: fk.assembly_at\[0\].q_nope: not an independent"):
        run(_scenario(tmp_path, "  assembly: all\n  assembly_at: [{q_nope: 1}]\n"))
    from mechkin.config.scenario import load_scenario

    with pytest.raises(ConfigError, match="assembly_at needs assembly: all"):
        load_scenario(_scenario(tmp_path, "  assembly_at: [{q_crank: 1}]\n"))


def test_direct_drive_crossed_mode_is_flagged_outside_the_limits():
    """kim1995's direct-drive arm: the parallelogram closes in two ways; the crossed one puts
    a passive joint outside its [5, 175] deg limits (flagged, not dropped)."""
    mech = load_mechanism(ROOT / "mechanisms" / "kim1995_direct_drive.yaml")
    modes = assembly_modes(mech, mech.home[mech.independent], starts=128)
    assert modes.count == 2
    assert modes.within_limits.tolist() == [True, False]
    q = modes.q[1]
    assert np.any((q < mech.lower - 1e-9) | (q > mech.upper + 1e-9))
    assert np.abs(closure_residual(mech, forward_kinematics(mech, modes.q))).max() < 1e-9
