r"""Compiled path-plan forward kinematics (optional accelerator, needs ``numba``).

One kernel, :func:`plan_poses`, evaluates a :class:`mechkin.model.kinematics._PathPlan` for m
configurations: per configuration and path joint ``X_i = X_parent C_i Z(q_i)`` as 3x4 affine
products (kim1995 Eq. (2), constants folded as in the plan), then each requested frame
``X_step E_f``. The operations are those of the plain-Python route
(:func:`mechkin.model.kinematics._plan_one`) in the same order, so both agree to round-off
(tests/model/test_fast_fk.py checks 1e-12 against the tree FK).

The plan comes in as one array (few arguments keep numba's dispatch cheap), ``plan``
(p + k, 16): per path joint the top 3 rows of ``C_i`` (12 values, row-major), then the joint
index, 1.0 revolute / 0.0 prismatic and the parent step (-1: the base), as floats (exact);
then per frame the top rows of ``E_f`` and its step (-1: the base). The output ``out``
(m, k, 4, 4) is allocated by the caller.

Importing this module imports numba (about 0.5 s); :mod:`mechkin.model.fk_accel` decides when
that pays and imports it (:func:`mechkin.model.fk_accel.load`) after picking the cache
folder. ``cache=True``: compiled once per machine (``mechkin warmup`` can do it ahead,
:func:`mechkin.model.fk_accel.warm`).

Design
------
Part of :mod:`mechkin.model`. Imports numpy and numba only (no mechkin module: fk_accel
imports this one).
"""

from __future__ import annotations

import numba
import numpy as np

#: The one signature :func:`ready` compiles (other argument types then raise TypeError
#: instead of compiling anew; the caller normalises them): qs (m, n), plan (p + k, 16), out
#: (m, k, 4, 4), all float64, C-ordered and writable.
SIGNATURE = "void(float64[:, ::1], float64[:, ::1], float64[:, :, :, ::1])"


def ready():
    """The kernel compiled (or loaded from numba's cache) for :data:`SIGNATURE` only."""
    if not plan_poses.signatures:
        plan_poses.compile(SIGNATURE)
        plan_poses.disable_compile()
    return plan_poses


@numba.njit(cache=True, nogil=True)
def plan_poses(qs, plan, out):  # pragma: no cover - compiled (tests run it compiled)
    """Poses out (m, k, 4, 4) of the plan's k frames for configurations qs (m, n)."""
    m = qs.shape[0]
    k = out.shape[1]
    p = plan.shape[0] - k
    X = np.empty((max(p, 1), 12))
    for r in range(m):
        for i in range(p):
            C = plan[i]
            v = qs[r, int(C[12])]
            pi = int(C[14])
            # L = C Z(q): revolute mixes C's first two columns, prismatic shifts the last one
            if C[13] != 0.0:
                c = np.cos(v)
                s = np.sin(v)
                l00 = C[0] * c + C[1] * s
                l01 = C[1] * c - C[0] * s
                l10 = C[4] * c + C[5] * s
                l11 = C[5] * c - C[4] * s
                l20 = C[8] * c + C[9] * s
                l21 = C[9] * c - C[8] * s
                l03, l13, l23 = C[3], C[7], C[11]
            else:
                l00, l01, l10, l11, l20, l21 = C[0], C[1], C[4], C[5], C[8], C[9]
                l03 = C[3] + C[2] * v
                l13 = C[7] + C[6] * v
                l23 = C[11] + C[10] * v
            l02, l12, l22 = C[2], C[6], C[10]
            Xi = X[i]
            if pi < 0:
                Xi[0], Xi[1], Xi[2], Xi[3] = l00, l01, l02, l03
                Xi[4], Xi[5], Xi[6], Xi[7] = l10, l11, l12, l13
                Xi[8], Xi[9], Xi[10], Xi[11] = l20, l21, l22, l23
            else:
                Xp = X[pi]
                for a in range(0, 12, 4):
                    a0 = Xp[a]
                    a1 = Xp[a + 1]
                    a2 = Xp[a + 2]
                    a3 = Xp[a + 3]
                    Xi[a] = a0 * l00 + a1 * l10 + a2 * l20
                    Xi[a + 1] = a0 * l01 + a1 * l11 + a2 * l21
                    Xi[a + 2] = a0 * l02 + a1 * l12 + a2 * l22
                    Xi[a + 3] = a0 * l03 + a1 * l13 + a2 * l23 + a3
        for f in range(k):
            E = plan[p + f]
            st = int(E[12])
            o = out[r, f]
            for a in range(3):
                if st < 0:
                    for b in range(4):
                        o[a, b] = E[4 * a + b]
                else:
                    a0 = X[st, 4 * a]
                    a1 = X[st, 4 * a + 1]
                    a2 = X[st, 4 * a + 2]
                    a3 = X[st, 4 * a + 3]
                    for b in range(3):
                        o[a, b] = a0 * E[b] + a1 * E[4 + b] + a2 * E[8 + b]
                    o[a, 3] = a0 * E[3] + a1 * E[7] + a2 * E[11] + a3
            o[3, 0] = 0.0
            o[3, 1] = 0.0
            o[3, 2] = 0.0
            o[3, 3] = 1.0
