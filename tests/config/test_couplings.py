"""Joint couplings (``couplings:``, URDF ``<mimic>``): constraint rows of phi solved with the loop
closure; rates and accelerations against finite differences of the solved positions; export ->
``<mimic>`` -> import keeps them; every refusal names file, line and fix."""

from __future__ import annotations

import numpy as np
import pytest

from mechkin.api import fk
from mechkin.errors import ConfigError
from mechkin.model import load_mechanism
from mechkin.model.differential import motion_derivatives
from mechkin.model.kinematics import closure_jacobian, forward_kinematics

#: a four-bar driving a rocker, with a coupled (mimic) finger on the rocker (prismatic, offset
#: in mm) and a coupled revolute on the crank: cuts and couplings in one phi
YAML = """name: coupled_fourbar
units: {length: mm, angle: deg}
links:
  - name: ground
    frames: [{name: rocker_pivot, xyz: [1000, 0, 0]}]
  - name: crank
  - name: coupler
    frames: [{name: coupler_end, xyz: [1000, 0, 0]}]
  - name: rocker
    frames: [{name: rocker_end, xyz: [800, 0, 0]}]
  - name: finger
    frames: [{name: tip, xyz: [0, 0, 50]}]
  - name: flap
joints:
  - {name: q_crank, type: revolute, parent: ground, child: crank, home: 60}
  - {name: q_coupler, type: revolute, parent: crank, child: coupler, origin: {xyz: [300, 0, 0]},
     home: -40}
  - {name: q_rocker, type: revolute, parent: rocker_pivot, child: rocker, home: 90}
  - {name: slide, type: prismatic, parent: rocker, child: finger, axis: [1, 0, 0],
     origin: {xyz: [400, 0, 0]}}
  - {name: flap, type: revolute, parent: crank, child: flap, axis: [1, 0, 0]}
cuts:
  - {name: pin, frames: [coupler_end, rocker_end], mask: [x, y]}
couplings:
  - {joint: slide, master: q_rocker, multiplier: 2.0, offset: 10.0}   # mm per deg, mm
  - {joint: flap, master: q_crank, multiplier: -0.5}
independent: [q_crank]
end_effector: tip
"""


@pytest.fixture()
def mech(tmp_path):
    p = tmp_path / "coupled.yaml"
    p.write_text(YAML)
    return load_mechanism(p)


def test_couplings_are_dependent_rows_of_phi(mech):
    assert mech.n_equations == 2 + 2 and mech.independent_names == ["q_crank"]
    assert set(mech.dependent_names) == {"q_coupler", "q_rocker", "slide", "flap"}
    qv = np.radians([[50.0], [65.0], [80.0]])
    res = fk(mech, qv, frames=["tip"])
    assert all(s == "converged" for s in res.status)
    i = mech.joint_index
    deg = np.pi / 180
    # SI: 2 mm/deg = 0.002 / (pi/180) m/rad, offset 10 mm
    assert np.allclose(res.q[:, i("slide")], 0.002 / deg * res.q[:, i("q_rocker")] + 0.010,
                       atol=1e-13, rtol=0)
    assert np.allclose(res.q[:, i("flap")], -0.5 * res.q[:, i("q_crank")], atol=1e-15, rtol=0)
    phi, J = closure_jacobian(mech, forward_kinematics(mech, res.q))
    assert np.abs(phi).max() < 1e-12 and J.shape == (3, 4, mech.n)


def test_rates_and_accelerations_follow_the_couplings(mech):
    """q(t) solved at t and t +- h (loop closure with couplings); the analytic rates and
    accelerations of every joint equal the central differences."""
    t = np.linspace(0.0, 1.0, 5)
    h = 1e-4

    def qv_of(t):
        return np.radians(55.0 + 10.0 * np.sin(1.3 * t))[:, None]

    def solve(tt):
        return fk(mech, qv_of(tt), frames=[]).q

    q, qp, qm = solve(t), solve(t + h), solve(t - h)
    qd_v = np.radians(13.0 * np.cos(1.3 * t))[:, None]
    qdd_v = np.radians(-16.9 * np.sin(1.3 * t))[:, None]
    md = motion_derivatives(mech, q, qd_v, qdd_v)
    assert np.allclose(md.qd, (qp - qm) / (2 * h), atol=1e-7, rtol=0)
    assert np.allclose(md.qdd, (qp - 2 * q + qm) / h**2, atol=2e-4, rtol=0)
    i, k = mech.joint_index("slide"), mech.joint_index("q_rocker")
    assert np.allclose(md.qdd[:, i], 0.002 / (np.pi / 180) * md.qdd[:, k], atol=1e-12)


def test_export_mimic_import_round_trip(mech, tmp_path):
    from mechkin.io.urdf_out import mechanism_to_urdf

    text = mechanism_to_urdf(mech)
    assert text.count("<mimic ") == 2
    p = tmp_path / "coupled.urdf"
    p.write_text(text)
    back = load_mechanism(p)
    assert [(back.joint_names[c.joint], back.joint_names[c.master]) for c in back.couplings] \
        == [(mech.joint_names[c.joint], mech.joint_names[c.master]) for c in mech.couplings]
    for a, b in zip(mech.couplings, back.couplings, strict=True):
        assert a.multiplier == pytest.approx(b.multiplier, abs=1e-15)
        assert a.offset == pytest.approx(b.offset, abs=1e-15)
    qv = np.radians([[50.0], [70.0]])
    T0 = fk(mech, qv, frames=["tip"]).poses["tip"]
    T1 = fk(back, qv, frames=["tip"]).poses["tip"]
    assert np.abs(T0 - T1).max() < 1e-12


@pytest.mark.parametrize("change, key, text", [
    ("{joint: slide, master: nope}", "couplings[0].master", "unknown joint 'nope'"),
    ("{joint: slide, master: slide}", "couplings[0].master", "cannot follow itself"),
])
def test_bad_coupling_is_one_line_with_the_key(tmp_path, change, key, text):
    p = tmp_path / "bad.yaml"
    bad = YAML.replace("{joint: slide, master: q_rocker, multiplier: 2.0, offset: 10.0}", change)
    p.write_text(bad)
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    (msg,) = exc.value.problems
    line = bad.splitlines().index(next(x for x in bad.splitlines() if change in x)) + 1
    assert msg.startswith(f"{p}:{line}: {key}: ") and text in msg


def test_coupled_joint_cannot_be_independent(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text(YAML.replace("independent: [q_crank]", "independent: [flap]"))
    with pytest.raises(ConfigError, match="flap.*is coupled"):
        load_mechanism(p)


def test_urdf_mimic_of_a_fixed_master_names_line_and_fix(tmp_path):
    p = tmp_path / "m.urdf"
    p.write_text("""<robot name="r">
  <link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
    <mimic joint="j1"/>
  </joint>
</robot>
""")
    with pytest.raises(ConfigError) as exc:
        load_mechanism(p)
    (msg,) = exc.value.problems
    assert msg.startswith(f"{p}:6: joint[j2].mimic.joint: ") and "fix:" in msg
