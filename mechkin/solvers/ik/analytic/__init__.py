"""Analytic inverse kinematics by subproblem decomposition, chosen by the joint axes.

================= =================================================================
``jit``        numba's njit when allowed, else plain Python
``subproblems`` Paden-Kahan 1-3 and IK-Geo 4 on 3-vectors (compiled)
``subproblems56`` IK-Geo 5 and 6 through one quartic on the unit circle (compiled)
``solve6r``    every branch of a 6R chain with a spherical wrist (any first three axes, or
               prismatic joints among them) or three parallel axes
``classify``   the decomposition a mechanism admits (or NotDecomposable naming the axes)
``solutions``  batched: every branch of many poses, wrapped into the limits, verified, merged
``finish``     limits, verification, order, merging (compiled); the single-pose entry
``scara``      4-DOF SCARA arms (numpy)
``arm5r``      5R arms with three parallel axes (numpy)
``arm5w``      5R arms whose last two axes meet: the 6R wrist solver with a virtual q6 = 0
``search1d``   6R arms whose h5 meets h6 (or h1 meets h2) without a closed form: IK-Geo's
               1-D search over q4 (``method: analytic`` only; ``complete: false``)
``dispatch``   ``method: auto | analytic`` for one pose (IkResult), nearest the guess
``api_ik``     the route of mechkin.ik (single, batched, held joints, sampled self-motion)
``legs``       legs of parallel mechanisms from the platform pose (U-P-S)
================= =================================================================

References
----------
Paden (1986); Murray, Li & Sastry (1994) §3.2-3.3; Elias & Wen, IK-Geo, arXiv 2211.05737.
"""
