"""Result and report records: the only types ``mechkin.io`` sees (DESIGN.md: records).

A task (``mechkin.tasks.<x>.run``) turns a validated scenario into a :class:`Report`: the
summary that becomes ``summary.json``, the ``expect:`` results, and one task record
(``data``) that holds plain arrays for the task's writer in ``mechkin.io`` (CSV columns, plot
series, MCAP frame trees). Nothing here solves or writes files: :meth:`Report.write` calls the
writer installed with :func:`set_report_writer` (the task layer installs
:func:`mechkin.tasks.write.write_report`, which hands the report to
:func:`mechkin.io.report.write_report`), so records know nothing of io.

Imports: numpy and the standard library only (records sit under io/ and tasks/).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mechkin.errors import EXIT_CODES, EXIT_EXPECT, EXIT_OK, EXIT_SOLVER
from mechkin.records.motion import MotionRecord

EXPECT_FAILED = "expect failed"

__all__ = ["EXIT_CODES", "EXPECT_FAILED", "FkResult", "MotionRecord", "OutputFlags", "Report",
           "set_report_writer"]

#: The function behind :meth:`Report.write`: ``write(report, out_dir, plots=...) -> summary``.
_REPORT_WRITER: Callable[..., dict[str, Any]] | None = None


def set_report_writer(write: Callable[..., dict[str, Any]]) -> None:
    """Install the function that :meth:`Report.write` calls (``write(report, out_dir,
    plots=...)`` returning the final summary). Importing :mod:`mechkin.tasks` installs
    :func:`mechkin.tasks.write.write_report`; records themselves never import io."""
    global _REPORT_WRITER
    _REPORT_WRITER = write


@dataclass
class FkResult:
    """Forward kinematics of a batch (:func:`mechkin.fk`).

    Attributes
    ----------
    q : array (m, n)
        Every joint [rad | m] (independent as given, dependent from the loop closure).
    status : list of str
        Per row: ``converged``, ``outside limits``, ``constraint singularity``, ``not
        converged`` or ``singular``.
    residual : array (m,)
        ||phi_R|| at exit (0 for open chains).
    iterations : array (m,)
        Newton iterations of the loop closure.
    poses : dict of str to array (m, 4, 4)
        Pose of each requested frame in the base frame.
    joint_names : list of str
    """

    q: Any
    status: list[str]
    residual: Any
    iterations: Any
    poses: dict[str, Any]
    joint_names: list[str]
    #: closed chains: per row, every passive (dependent) joint within its limits
    within_limits: list[bool] | None = None
    #: closed chains: where the rows were reached from by continuation, ``"home"`` (the home
    #: assembly) or ``"guess"`` (the given ``q_w0``)
    assembly_from: str | None = None
    #: closed chains: per row, whether the continuation path that reached it (from the home
    #: assembly, or from the guess) crossed a constraint singularity, a change point where two
    #: assembly modes meet (the fk task's label ``constraint singularity crossed``); the row
    #: is on the smooth continuation of the branch it came from, its status stays
    #: ``converged``. False for a row solved by Newton from its own guess (no path).
    singularity_crossed: list[bool] | None = None

    @property
    def ok(self) -> bool:
        """Every row converged."""
        return all(s == "converged" for s in self.status)


@dataclass(frozen=True)
class OutputFlags:
    """Which kinds of output the scenario asks for (``outputs: {csv, plots, mcap, table}``;
    ``table``: the format of the tables, csv, npz or parquet)."""

    csv: bool = True
    plots: bool = True
    mcap: bool = True
    table: str = "csv"


@dataclass
class Report:
    """Everything one run produced, before any file is written.

    Attributes
    ----------
    task : str
        ``fk``, ``ik``, ``track``, ``workspace`` or ``biped``.
    scenario : str
        The scenario's name (default output folder ``outputs/<scenario>``).
    summary : dict
        The content of summary.json without ``out_dir`` and ``files`` (added when written).
    checks : list of dict
        The ``expect:`` results (also under ``summary["expect"]`` when there are any).
    solver_ok : bool
        Every step / target / plan reached its goal.
    writer : str
        Name of the writer module ``mechkin.io.<writer>_out`` that turns ``data`` into files.
    data : object
        The task record the writer reads (e.g. :class:`MotionRecord`).
    outputs : OutputFlags
        The scenario's ``outputs:`` switches.
    scenario_path : Path, optional
        The scenario file (for messages).
    messages : list of str
        Lines the CLI prints on stderr after the run (e.g. why a plan is infeasible).
    """

    task: str
    scenario: str
    summary: dict[str, Any]
    checks: list[dict[str, Any]] = field(default_factory=list)
    solver_ok: bool = True
    writer: str = "motion"
    data: Any = None
    outputs: OutputFlags = field(default_factory=OutputFlags)
    scenario_path: Path | None = None
    messages: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        # honest statuses: a run whose solver succeeded but whose expect: failed says so
        if self.solver_ok and not self.expect_ok and self.summary.get("status") == "ok":
            self.summary["status"] = EXPECT_FAILED

    @property
    def status(self) -> str:
        """The run's status string (``summary["status"]``)."""
        return str(self.summary.get("status", "?"))

    @property
    def expect_ok(self) -> bool:
        """Every ``expect:`` entry held (True when there are none)."""
        return all(c.get("ok", False) for c in self.checks)

    @property
    def failure_asserted(self) -> bool:
        """An ``expect:`` entry states a status word (``{key: status, value: unreachable}``):
        the scenario says how the solver ends, so its expects alone judge the run."""
        return any(c.get("unit") == "word" for c in self.checks)

    @property
    def ok(self) -> bool:
        """Every expect held, and the solver succeeded or an expect states its status."""
        return self.expect_ok and (self.solver_ok or self.failure_asserted)

    @property
    def exit_code(self) -> int:
        """0 all good; 1 a solver did not reach its goal (unasserted); 5 an expect failed."""
        if self.ok:
            return EXIT_OK
        if not self.solver_ok and not self.failure_asserted:
            return EXIT_SOLVER
        return EXIT_EXPECT

    def write(self, out_dir: str | Path | None = None, *, plots: bool = True) -> dict[str, Any]:
        """Write every output into ``out_dir`` (default ``outputs/<scenario>``), atomically;
        return the final summary (with ``out_dir`` and ``files``)."""
        if _REPORT_WRITER is None:
            raise RuntimeError("Report.write: no report writer installed; import mechkin.tasks "
                               "(mechkin.run does) or call mechkin.io.report.write_report")
        out = Path(out_dir) if out_dir is not None else Path("outputs") / self.scenario
        return _REPORT_WRITER(self, out, plots=plots)
