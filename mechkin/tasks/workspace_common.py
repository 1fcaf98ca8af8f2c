"""What the workspace task's kinds share: the sample budget, progress bar, report, listed poses.

Used by :mod:`mechkin.tasks.workspace` and its kinds (:mod:`~mechkin.tasks.workspace_lee`,
:mod:`~mechkin.tasks.workspace_sweeps`). Split out of ``workspace.py`` (issue 23: modules that
fit in a head).

Imports: config, model, records, tasks.common, tasks.progress (never io/ or cli/).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mechkin.config.scenario import Scenario
from mechkin.config.units import length_factor
from mechkin.errors import ConfigError
from mechkin.records import Report
from mechkin.records.workspace import WorkspaceOutput
from mechkin.tasks.common import expect_messages, output_flags, with_expect

MAX_SWEEP_SAMPLES = 5_000_000

def _progress_bar(ex: dict[str, Any], description: str, deadline: bool = True) -> Any:
    """The shared progress bar (:mod:`mechkin.tasks.progress`) for the resolved options
    (``deadline=False``: the sweep stops at its own safe points under --max-time)."""
    from mechkin.tasks.progress import progress_bar

    flag = False if not ex["progress"] else (True if ex["force_terminal"] else None)
    return progress_bar(flag, description, deadline)


def _head(sc: Scenario, kind: str) -> dict[str, Any]:
    return {"scenario": sc.name, "task": "workspace", "kind": kind, "status": "ok"}


def _report(sc: Scenario, summary: dict[str, Any], out: WorkspaceOutput,
            first: dict[str, Any] | None = None) -> Report:
    """The report: expects evaluated on ``summary``; ``first`` (the solver's own summary)
    leads the written summary.json, in its key order."""
    checks = with_expect(summary, sc)
    full = {**first, **summary} if first is not None else summary
    return Report(task="workspace", scenario=sc.name, summary=full, checks=checks,
                  solver_ok=True, writer="workspace", data=out, outputs=output_flags(sc),
                  scenario_path=sc.path, messages=expect_messages(checks, sc.path))


def _listed_poses(sc: Scenario, columns: tuple[str, ...], optional: tuple[str, ...] = ()
                  ) -> np.ndarray | None:
    """The section's ``poses`` (inline rows) or ``poses_csv`` (columns ``columns`` and, all
    or none, ``optional``) as an array (m, k) in the file's units; None when neither is given."""
    import csv

    spec = sc.section
    if spec.poses is not None:
        return np.asarray(spec.poses, dtype=np.float64)
    if spec.poses_csv is None:
        return None
    path = (sc.doc.path.parent / spec.poses_csv).resolve()
    if not path.is_file():
        raise ConfigError(f"{sc.doc.where(('workspace', 'poses_csv'))}: file not found: "
                          f"{spec.poses_csv} (resolved to {path})")
    from mechkin.config.guarded_read import MAX_TABLE_BYTES, check_file

    check_file(path, what="poses CSV", limit=MAX_TABLE_BYTES)  # a regular file, size capped
    with path.open(newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and any(c.strip() for c in r)]
    if len(rows) < 2:
        raise ConfigError(f"{path}:1: expected a header row and at least one pose")
    head = [h.strip() for h in rows[0]]
    missing = [c for c in columns if c not in head]
    if missing:
        extra = f" [{', '.join(optional)}]" if optional else ""
        raise ConfigError(f"{path}:1: missing column(s) {', '.join(missing)} (expected "
                          f"{', '.join(columns)}{extra})")
    given_opt = [c for c in optional if c in head]
    if given_opt and len(given_opt) != len(optional):
        raise ConfigError(f"{path}:1: give all of {', '.join(optional)} or none")
    cols = [head.index(c) for c in (*columns, *given_opt)]
    out = np.empty((len(rows) - 1, len(cols)))
    for i, r in enumerate(rows[1:], start=2):
        try:
            out[i - 2] = [float(r[c]) for c in cols]
        except (ValueError, IndexError):
            raise ConfigError(f"{path}:{i}: expected numbers in {', '.join(head[c] for c in cols)}"
                              ) from None
    if not np.all(np.isfinite(out)):
        raise ConfigError(f"{path}:1: non-finite numbers in the poses")
    if given_opt and np.any(np.sum(out[:, len(columns):] ** 2, axis=1) < 1e-18):
        raise ConfigError(f"{path}:1: expected non-zero quaternions (qw, qx, qy, qz)")
    if out.shape[0] > MAX_SWEEP_SAMPLES:
        raise ConfigError(f"{path}:1: {out.shape[0]} poses, more than {MAX_SWEEP_SAMPLES}")
    return out


def _sweep_frame(sc: Scenario, mech: Any) -> int:
    """The frame a sweep maps: ``workspace.frame`` or the mechanism's end effector."""
    spec = sc.section
    if spec.frame is not None:
        if spec.frame not in mech.frame_names:
            raise ConfigError(f"{sc.doc.where(('workspace', 'frame'))}: unknown frame "
                              f"{spec.frame!r}")
        return mech.frame_index(spec.frame)
    if mech.end_effector is not None:
        return int(mech.end_effector)
    raise ConfigError(f"{sc.doc.where(('workspace',))}: the mechanism has no end_effector; "
                      "give frame")


NORMALIZED_DEFINITION = (
    "sigma_min / sigma_max of the Jacobian with its translational rows divided by the "
    "characteristic length L (prismatic columns multiplied by L): dimensionless, so invariant "
    "under a change of length unit (the raw isotropy is not); unlike lee's sigma_KI, which "
    "uses Euler-angle rates of a purely rotational mechanism, it uses the angular velocity")


def _char_length(sc: Scenario) -> float | None:
    L = sc.section.characteristic_length
    return None if L is None else float(L) * length_factor(sc.spec.units.length)


def _char_length_entry(sc: Scenario, value: float | None) -> dict[str, Any]:
    given = sc.section.characteristic_length is not None
    return {"value_m": value, "source": "scenario" if given else
            "minimised: the L maximising the mean normalized isotropy (global conditioning "
            "index) over the reachable samples"}


def _joint_columns(mech: Any) -> list[str]:
    return [f"{n}_{'m' if mech.s[mech.independent[i]] == 1 else 'rad'}"
            for i, n in enumerate(mech.independent_names)]
