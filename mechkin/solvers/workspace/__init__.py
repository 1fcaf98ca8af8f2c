r"""Workspace analysis: isotropy maps, joint-space and task-space sweeps, dexterity measures.

Owns lee's workspace and isotropy maps over orientation grids (``maps``, lee Figs. 2-5), the
dexterity of a frame Jacobian (``dexterity``: singular values, isotropy, condition number,
manipulability), joint-space sweeps of any mechanism (``joint_sweep``), lee's design sweeps
(``sweeps``), task-space sweeps (``task_space``) and the execution of independent jobs on
processes or a Dask cluster (``jobs``).

May import: ``mechkin.model``, ``mechkin.spatial``, ``mechkin.records``, ``mechkin.errors``,
``mechkin.config`` (mechanism files of design sweeps), ``mechkin.solvers.ik`` and
``mechkin.solvers.closed_form``; never ``tasks``, ``io`` or ``cli``.
"""
