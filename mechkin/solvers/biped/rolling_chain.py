r"""The blade's contact with the plane as a virtual chain closed by a cut (hwang2023 §2.3, a loop).

hwang2023 §2.3 solves "blade point E known, ankle angle theta6 given, blade tilt beta_Y unknown" in
closed form for its 6R leg. Here the same problem is posed for the general complex-chain model
(kim1995 §2): a virtual chain leaves the base at the contact base frame 0_i' (``Delta_i`` of Eq. 21
placed at E), turns about the blade's long axis by a virtual revolute joint (the rolling joint,
angle beta_Y, axis ``-Y`` on the right leg and ``+Y`` on the left, Table 1) and ends in a frame
that a cut identifies with the leg's blade frame (6 equations). theta6 (and every joint outside
the loop) is independent; the leg joints theta1..5 and beta_Y are the dependent joints found by the
Newton-Raphson loop closure (:func:`mechkin.model.closure.solve_closure`). Nothing here knows the
leg's structure, so any leg described in a mechanism file is handled the same way.

References
----------
hwang2023_hybrid_walking_skating_ik §2.3, Eq. (21), Table 1; kim1995_complex_chain_ik §2, §5.1.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from mechkin.config.schema import MechanismSpec
from mechkin.model import Mechanism
from mechkin.model.build import build_mechanism
from mechkin.model.closure import ClosureStatus, solve_closure
from mechkin.spatial.rotations import matrix_from_rpy, rpy_from_matrix

__all__ = ["ChainSolution", "rolling_contact_mechanism", "solve_blade_tilt_by_closure"]

ROLL_AXIS = {"right": (0.0, -1.0, 0.0), "left": (0.0, 1.0, 0.0)}
"""Axis of the rolling joint in the contact base frame: Psi_1 = Delta_1 Rot(-Y, beta_Y),
Psi_2 = Delta_2 Rot(+Y, beta_Y) (hwang2023 Table 1)."""


@dataclass(frozen=True)
class ChainSolution:
    """Loop-closure solution: ``q_leg`` (k,) [rad] of the named leg joints, ``beta`` the rolling
    joint [rad], ``status`` ("converged", "not converged", "singular"), ``residual`` ||phi||."""

    q_leg: np.ndarray
    beta: float
    status: str
    residual: float
    iterations: int
    q: np.ndarray
    mechanism: Mechanism

    @property
    def ok(self) -> bool:
        return self.status == ClosureStatus.CONVERGED.value


def rolling_contact_mechanism(spec: MechanismSpec, *, blade_frame: str,
                              T_base_contact: ArrayLike, axis: Sequence[float],
                              dependent: Sequence[str], tag: str = "contact") -> Mechanism:
    """Add the virtual rolling chain to an SI mechanism spec and build it.

    Parameters
    ----------
    spec : MechanismSpec
        The mechanism in SI (``mechkin.config.mechanism_file.read_mechanism_spec``).
    blade_frame : str
        The leg's frame that must coincide with the contact frame (axes as Psi_i, Table 1).
    T_base_contact : array, shape (4, 4)
        Pose of the contact base frame 0_i' (``Delta_i`` at E) in the base link's frame.
    axis : 3 floats
        Rolling axis in the contact base frame (:data:`ROLL_AXIS`).
    dependent : sequence of str
        The leg joints the closure solves (theta1..5); the rolling joint ``<tag>_beta`` is added
        to them, every other joint is independent.

    Returns
    -------
    Mechanism
        With the link ``<tag>_link``, the joint ``<tag>_beta`` and the cut ``<tag>_cut``.
    """
    T = np.asarray(T_base_contact, dtype=np.float64)
    rpy = rpy_from_matrix(T[:3, :3])
    if not np.allclose(matrix_from_rpy(rpy), T[:3, :3], atol=1e-12):
        raise ValueError("T_base_contact: rotation not representable by rpy (gimbal lock)")
    d = spec.model_dump()
    base = spec.base or spec.links[0].name
    link = next(lk for lk in d["links"] if lk["name"] == base)
    link["frames"] = list(link["frames"]) + [
        {"name": f"{tag}_base", "xyz": T[:3, 3].tolist(), "rpy": rpy.tolist()}]
    d["links"].append({"name": f"{tag}_link", "frames": [{"name": f"{tag}_frame"}]})
    d["joints"].append({"name": f"{tag}_beta", "type": "revolute", "parent": f"{tag}_base",
                        "child": f"{tag}_link", "axis": list(map(float, axis)),
                        "limits": [-0.5 * np.pi, 0.5 * np.pi]})
    d["cuts"] = list(d.get("cuts") or []) + [
        {"name": f"{tag}_cut", "frames": [blade_frame, f"{tag}_frame"]}]
    dep = set(dependent) | {f"{tag}_beta"}
    d["independent"] = [j["name"] for j in d["joints"] if j["name"] not in dep]
    return build_mechanism(MechanismSpec.model_validate(d))


def solve_blade_tilt_by_closure(spec: MechanismSpec, *, leg_joints: Sequence[str],
                                blade_frame: str, side: str, T_base_contact: ArrayLike,
                                theta6: float, q_guess: ArrayLike, beta_guess: float = 0.0,
                                max_iter: int = 100) -> ChainSolution:
    """hwang2023 §2.3 ("theta6 known, beta_Y unknown") by the general loop-closure solver.

    Parameters
    ----------
    leg_joints : sequence of 6 str
        theta1..theta6 of the leg (the last is the known ankle joint).
    side : {"right", "left"}
        Picks the rolling axis (:data:`ROLL_AXIS`).
    T_base_contact : array, shape (4, 4)
        ``[Delta_i | E]`` in the base link's frame (for a body at T_0_G: inv(T_0_G) @ [Delta | E]).
    theta6 : float
        The known ankle angle [rad].
    q_guess : array, shape (6,)
        Start of the Newton-Raphson iteration for theta1..6 (theta6 is ignored).
    """
    if side not in ROLL_AXIS:
        raise ValueError(f"expected side 'right' or 'left', got {side!r}")
    names = list(leg_joints)
    mech = rolling_contact_mechanism(spec, blade_frame=blade_frame, T_base_contact=T_base_contact,
                                     axis=ROLL_AXIS[side], dependent=names[:5])
    q0 = mech.home.copy()
    guess = np.asarray(q_guess, dtype=np.float64)
    for n, v in zip(names[:5], guess[:5], strict=True):
        q0[mech.joint_index(n)] = v
    q0[mech.joint_index(names[5])] = theta6
    q0[mech.joint_index("contact_beta")] = beta_guess
    res = solve_closure(mech, q0[mech.independent][None], q0[mech.dependent][None],
                        max_iter=max_iter)
    q = res.q[0]
    idx = [mech.joint_index(n) for n in names]
    return ChainSolution(q[idx].copy(), float(q[mech.joint_index("contact_beta")]),
                         res.status[0].value, float(res.residual[0]), int(res.iterations[0]),
                         q.copy(), mech)
