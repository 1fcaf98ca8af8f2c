"""Closed forms of particular mechanisms, checked against the general solvers (kim1995, lee).

Owns the kim1995 direct-drive arm (``direct_drive``, appendix 1: every sign branch), the
Stewart platform's leg lengths (``stewart``, §6.2), lee's spherical RRPS mechanism
(``lee_geometry``: geometry, orientation, inverse position; ``lee_forward``: every assembly mode
of the forward position; ``lee_spherical``: rates, isotropy, Newton forward position), the
recognition of which closed form solves a mechanism by its structure (``recognise``) and every
closed-form solution of a target, verified like the numerical ones (``all_solutions``).

The inverse kinematics of these three are cases of the leg decomposition of
:mod:`mechkin.solvers.ik.analytic.legs` (``recognise.closed_form_solutions`` solves through the
legs; the formulas here stay as the paper's statements, references in the tests, and the route
for a mechanism that fits a form but whose legs do not decompose).

May import: ``mechkin.model``, ``mechkin.spatial``, ``mechkin.config``, ``mechkin.errors``,
``mechkin.solvers.ik``, ``mechkin.solvers.assembly`` and ``mechkin.solvers.result``; never
``tasks``, ``io`` or ``cli`` (docs/ARCHITECTURE.md).
"""
