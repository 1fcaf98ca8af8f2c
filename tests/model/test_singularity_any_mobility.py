"""Singularities of any mobility (issue 24): a 1-DOF linkage's dead centres, a four-bar's limit
positions, and a workspace's characteristic length bounded by the mechanism's size."""

from __future__ import annotations

import numpy as np
import pytest

import mechkin
from mechkin.model.singularity import SingularityKind, classify
from tests.model import closed_chain_models as M
from tests.model.test_continuation import load

R, ROD, E = 0.05, 0.2, 0.01  # the slider-crank of closed_chain_models.SLIDER


def test_slider_crank_dead_centres_are_inverse_kinematic_singularities(tmp_path):
    mech, _ = load(tmp_path, M.SLIDER)
    # crank and rod in line: extended sin q = e / (l + r); folded q = pi + asin(e / (l - r))
    dead = np.array([np.arcsin(E / (ROD + R)), np.pi + np.arcsin(E / (ROD - R))])
    regular = np.radians([60.0, 120.0, -90.0])
    q = M.slider_closed_form(np.concatenate([dead, regular]))
    rep = classify(mech, q)
    assert list(rep.kind[:2]) == [SingularityKind.INVERSE_KINEMATIC] * 2
    assert all(k is SingularityKind.REGULAR for k in rep.kind[2:])
    # one column: its singular value against the unit scale, dx/dq / L (not cond = 1)
    L = rep.length_scale
    ys = R * np.sin(regular) - E
    dxdq = -R * np.sin(regular) - ys * R * np.cos(regular) / np.sqrt(ROD**2 - ys**2)
    np.testing.assert_allclose(rep.ratio_reduced[2:], np.minimum(1.0, np.abs(dxdq) / L),
                               rtol=1e-6)


def test_slider_driven_crank_dead_centres_are_constraint_singularities(tmp_path):
    mech, _ = load(tmp_path, M.SLIDER, **{"independent: [crank_joint]": "independent: [slide]",
                                           "limits: [0.14, 0.26]": "limits: [0.1, 0.3]"})
    dead = np.array([np.arcsin(E / (ROD + R)), np.pi + np.arcsin(E / (ROD - R))])
    q = M.slider_closed_form(dead)
    rep = classify(mech, q)
    assert all(k in (SingularityKind.CONSTRAINT, SingularityKind.BOTH) for k in rep.kind)
    ok = classify(mech, M.slider_closed_form(np.radians([60.0, 200.0])))
    assert all(k is SingularityKind.REGULAR for k in ok.kind)


def test_rocker_driven_fourbar_limit_positions_are_constraint_singularities():
    from pathlib import Path

    text = (Path(__file__).parents[1] / "data" / "fourbar.yaml").read_text()
    text = text.replace("independent: [q_crank]", "independent: [q_rocker]")
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "fb.yaml"
        p.write_text(text)
        mech = mechkin.load_mechanism(p)
    # crank 0.3 and coupler 1.0 in line (extended 1.3, folded 0.7) meet the rocker 0.8 about
    # (1, 0): the rocker's limit positions
    rows = []
    for reach in (1.3, 0.7):
        P = M.circle_meet(np.zeros((1, 2)), reach, np.array([[1.0, 0.0]]), 0.8, 1.0)[0]
        th = np.arctan2(P[1], P[0])
        rows.append([th, 0.0 if reach > 1 else np.pi, np.arctan2(P[1], P[0] - 1.0)])
    rep = classify(mech, np.array(rows))
    assert all(k in (SingularityKind.CONSTRAINT, SingularityKind.BOTH) for k in rep.kind)


SCARA = """
name: scara4
units: {length: m, angle: deg}
links:
  - name: base
  - name: link1
  - name: link2
  - name: quill
  - name: tool
    frames:
      - {name: flange, xyz: [0, 0, 0]}
joints:
  - {name: j1, type: revolute, parent: base, child: link1, origin: {xyz: [0, 0, 0.2]},
     limits: [-130, 130]}
  - {name: j2, type: revolute, parent: link1, child: link2, origin: {xyz: [0.25, 0, 0]},
     limits: [-145, 145]}
  - {name: j3, type: prismatic, parent: link2, child: quill, origin: {xyz: [0.2, 0, 0]},
     axis: [0, 0, -1], limits: [0, 0.15]}
  - {name: j4, type: revolute, parent: quill, child: tool, limits: [-360, 360]}
independent: [j1, j2, j3, j4]
end_effector: flange
"""


def test_scara_characteristic_length_within_reach_and_isotropy_recomputed(tmp_path):
    # a 4-DOF SCARA (arms 0.25 + 0.2 m = reach 0.45 m, quill stroke 0.15 m): the prismatic
    # column turns nothing, which used to drive the search for L to 4e147 m
    (tmp_path / "scara.yaml").write_text(SCARA)
    sc = tmp_path / "ws.yaml"
    sc.write_text("name: scara_ws\ntask: workspace\nmechanism: scara.yaml\n"
                  "units: {length: m, angle: deg}\nworkspace:\n  kind: joint_sweep\n"
                  "  method: monte_carlo\n  samples: 400\n  joints:\n"
                  "    j1: {range: [-130, 130]}\n    j2: {range: [-145, 145]}\n"
                  "    j3: {range: [0, 0.15]}\n    j4: {range: [-180, 180]}\n")
    try:
        rep = mechkin.run(sc)
    except mechkin.ConfigError as exc:  # pragma: no cover - a schema difference, say which
        pytest.fail(str(exc))
    rec = rep.data.record
    L = rec.characteristic_length
    assert rep.summary["characteristic_length"]["value_m"] == L
    assert 0.0 < L <= 0.45 + 1e-12
    q = np.asarray(rec.q)
    # the SCARA's Jacobian (omega; v of the flange) written out in numpy: flange at
    # p = (0.25 c1 + 0.2 c12, 0.25 s1 + 0.2 s12, 0.2 - d3), every revolute axis along z
    c1, s1 = np.cos(q[:, 0]), np.sin(q[:, 0])
    c12, s12 = np.cos(q[:, 0] + q[:, 1]), np.sin(q[:, 0] + q[:, 1])
    px, py = 0.25 * c1 + 0.2 * c12, 0.25 * s1 + 0.2 * s12
    J = np.zeros((len(q), 6, 4))
    J[:, 2, [0, 1, 3]] = 1.0
    J[:, 3, 0], J[:, 4, 0] = -py, px
    J[:, 3, 1], J[:, 4, 1] = -0.2 * s12, 0.2 * c12
    J[:, 5, 2] = -1.0
    mech = mechkin.load_mechanism(tmp_path / "scara.yaml")
    from mechkin.model.kinematics import forward_kinematics, frame_jacobian

    J_mk = frame_jacobian(mech, forward_kinematics(mech, q), mech.end_effector)
    np.testing.assert_allclose(J_mk, J, atol=1e-12)  # mechkin's own Jacobian agrees
    J[:, 3:6, :] /= L  # nondimensionalised: v rows / L, the prismatic column * L
    J[:, :, 2] *= L
    s = np.linalg.svd(J, compute_uv=False)
    iso = s[:, -1] / s[:, 0]
    reach = np.asarray(rec.reachable, bool) if hasattr(rec, "reachable") else slice(None)
    np.testing.assert_allclose(np.asarray(rec.isotropy_normalized)[reach], iso[reach],
                               rtol=1e-9, atol=1e-12)
    assert 0.05 < iso.mean() < 1.0
