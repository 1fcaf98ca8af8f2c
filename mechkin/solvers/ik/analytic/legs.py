r"""Legs of parallel mechanisms from the platform pose, by the same subproblem decomposition.

A parallel mechanism in mechkin is a tree closed by cut links (kim1995 §2): the platform (the
link carrying {E}) hangs on one leg, and every other leg ends in a link that a cut ties to a
frame of the platform. Given the platform pose, each leg is a serial chain with a known end
pose (the pose of the platform frame its cut names), so each leg is solved by
:func:`mechkin.solvers.ik.analytic.classify.classify` of its path and
:func:`mechkin.solvers.ik.analytic.solutions.analytic_batch` like an arm: a U-P-S leg (Stewart
platform, kim1995 §6.2) by ``POS_INT12_P`` (two meeting axes, the stroke from a quadratic,
the spherical joint by Subproblems 2 and 1). Every joint of the mechanism follows, actuated
and passive, each leg's branch nearest a reference configuration.

Legs of other structures (Delta R-(SS)2, 3-RRR, lee's RRPS with fewer than 6 joints per leg)
do not decompose into these 6-joint classes: :func:`platform_legs` raises NotDecomposable
naming the leg, and their closed forms (:mod:`mechkin.solvers.closed_form`) stay as they are.

Design
------
Part of :mod:`mechkin.solvers.ik.analytic`; imports numpy and the package.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechkin.model.mechanism import Mechanism
from mechkin.solvers.ik.analytic.classify import AnalyticChain, NotDecomposable, classify
from mechkin.solvers.ik.analytic.solutions import analytic_batch


@dataclass(frozen=True, eq=False)
class Leg:
    """One leg: its chain, the model joints (base first), the frame that ends it and the
    platform frame that frame must coincide with (-1: the platform link's own frame)."""

    chain: AnalyticChain
    joints: np.ndarray
    end_frame: int
    platform_frame: int


def platform_legs(mech: Mechanism) -> list[Leg]:
    """The legs of a parallel mechanism whose platform carries {E} (see the module
    docstring). Raises NotDecomposable naming a leg that does not decompose."""
    if mech.end_effector is None or not mech.cuts:
        raise NotDecomposable(f"mechanism {mech.name}: legs need a platform ({{E}}) and cuts")
    plat = int(mech.frame_link[mech.end_effector])
    ends = [(plat, -1)]
    for cut in mech.cuts:
        if not bool(np.all(cut.mask)):
            raise NotDecomposable(f"cut {cut.name}: a leg end needs all 6 components")
        if int(mech.frame_link[cut.b]) == plat:
            ends.append((int(cut.a), int(cut.b)))
        elif int(mech.frame_link[cut.a]) == plat:
            ends.append((int(cut.b), int(cut.a)))
        else:
            raise NotDecomposable(f"cut {cut.name} does not end on the platform "
                                  f"{mech.link_names[plat]}")
    legs = []
    for end, target in ends:
        try:
            chain = classify(mech, frame=end, check_independent=False)
        except NotDecomposable as exc:
            raise NotDecomposable(f"leg to {mech.frame_names[end]}: {exc}") from None
        legs.append(Leg(chain=chain, joints=chain.joints, end_frame=end,
                        platform_frame=target))
    return legs


def solve_legs(mech: Mechanism, legs: list[Leg], T_0_E: np.ndarray, q_ref: np.ndarray
               ) -> tuple[np.ndarray, bool]:
    """Every joint (n,) of the mechanism with {E} at T_0_E (4, 4): each leg's solution
    nearest q_ref (n,) (revolute joints at the turn nearest it, within the limits). Returns
    (q, ok); ok is False when a leg has no solution within its limits (q keeps q_ref there)."""
    e = int(mech.end_effector)
    T_0_plat = T_0_E @ np.linalg.inv(mech.frame_offset[e])
    q = np.array(q_ref, dtype=np.float64)
    ok = True
    for leg in legs:
        # the leg's end frame coincides with the platform frame its cut names
        T_end = T_0_plat if leg.platform_frame < 0 else \
            T_0_plat @ mech.frame_offset[leg.platform_frame]
        b = analytic_batch(mech, leg.chain, T_end[None], q[leg.joints])
        if b.count[0] == 0:
            ok = False
            continue
        q[leg.joints] = b.q_v[0, 0]
    return q, ok
