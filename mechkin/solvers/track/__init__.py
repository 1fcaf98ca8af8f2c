r"""The track task's numerics: a hand path, its inverse kinematics and a timing along it (park).

Owns the path geometry (``path_geometry``: p(r), R*(r) and their r-derivatives), the path of
park §3.1 and the dynamics along it (``path``), the path inverse kinematics of open chains
(``path_ik``, park Eq. (7), (9)-(11)) and of closed chains (``closed_path_ik``), the three
planners: the phase-plane dynamic programme (``dpct``, park §3-§4; its problem records in
``dp_problem``, its limit model in ``dp_limits``), TOPP-RA (``topp``, Pham & Pham 2018; the
constraint rows in ``topp_problem``, the two passes in ``topp_passes``) and the intercept plans
(``intercept`` by TOPP-RA, ``intercept_dp`` by the DP), and the planner choice (``plan``).

May import: ``mechkin.model``, ``mechkin.spatial``, ``mechkin.records``, ``mechkin.errors``,
``mechkin.solvers.result``, ``mechkin.solvers.ik`` and ``mechkin.solvers.dynamics``; never
``tasks``, ``io`` or ``cli``.
"""
