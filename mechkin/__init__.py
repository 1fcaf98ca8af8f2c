"""mechkin: kinematics analysis of open, closed and complex-chain robot mechanisms.

The Python API (stable; see the README's "Python API" section)::

    import mechkin
    mech = mechkin.load_mechanism("mechanisms/puma560.yaml")
    res = mechkin.fk(mech, q_v)                      # FkResult: q, status, poses
    sol = mechkin.Solver(mech)                       # plans and options kept: sol.pose(q),
                                                     # sol.fk(qs), sol.ik(T)
    sols = mechkin.ik(mech, targets)                 # list of IkResult, verified by FK
    report = mechkin.run("scenarios/puma560_wave_fk.yaml")   # Report: summary, status
    report.write("outputs/wave")                     # the CLI's files

Frames: ``T_a_b`` is the pose of frame b expressed in frame a (maps b-coordinates to a), so
``T_a_c = T_a_b @ T_b_c``. Units are SI inside (m, rad, s, N m).

The names are loaded on first use, so ``import mechkin`` (and ``mechkin --help``) imports no
numpy.
"""

from __future__ import annotations

from typing import Any

__version__ = "0.1.0"

__all__ = [
    "ConfigError",
    "FkResult",
    "IkResult",
    "MechkinError",
    "Mechanism",
    "Report",
    "Scenario",
    "Solver",
    "__version__",
    "fk",
    "ik",
    "ik_frames",
    "load_mechanism",
    "load_scenario",
    "run",
]

_WHERE = {
    "fk": "mechkin.api", "ik": "mechkin.api", "ik_frames": "mechkin.api",
    "load_mechanism": "mechkin.api",
    "load_scenario": "mechkin.api", "run": "mechkin.api",
    "FkResult": "mechkin.records", "Report": "mechkin.records",
    "IkResult": "mechkin.solvers.ik", "Mechanism": "mechkin.model",
    "Scenario": "mechkin.config.scenario", "Solver": "mechkin.api",
    "MechkinError": "mechkin.errors", "ConfigError": "mechkin.errors",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        import importlib

        value = getattr(importlib.import_module(_WHERE[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mechkin' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
