"""The solvers, in rooms by what they solve (docs/ARCHITECTURE.md: the rooms and who may import
whom).

``ik/`` (numerical and every-solution IK), ``closed_form/`` (mechanism-specific closed forms),
``track/`` (path geometry, path IK, the DP, TOPP-RA, intercept), ``dynamics/`` (open and closed
chains), ``workspace/`` (maps, sweeps, dexterity, jobs), ``biped/`` (hwang2023), and the
modules ``distributed`` (trajectories in chunks), ``assembly`` (every assembly mode of a closed
chain) and ``result`` (Status and the shared result records).

Solvers import :mod:`mechkin.model`, :mod:`mechkin.spatial`, :mod:`mechkin.records`,
:mod:`mechkin.config` and :mod:`mechkin.errors`, and only the rooms their row of
docs/ARCHITECTURE.md allows; never ``tasks``, ``io``, ``cli`` or the API.
"""
