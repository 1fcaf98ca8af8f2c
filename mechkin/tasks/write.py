"""Writing a report: the task layer's one door to :mod:`mechkin.io` (DESIGN.md: data flow).

Records know nothing of io, so :meth:`mechkin.records.Report.write` calls the writer that
:mod:`mechkin.tasks` installs at import (:func:`mechkin.records.set_report_writer`): this
module's :func:`write_report`, which hands the report to
:func:`mechkin.io.report.write_report`. Every report a task returns was made after
``mechkin.tasks`` was imported, so ``report.write(out_dir)`` always works.

Imports: :mod:`mechkin.io.report` (inside the function: io, matplotlib and mcap load only when
a run writes). The only module of ``tasks/`` that imports io.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mechkin.records import Report


def write_report(report: Report, out_dir: str | Path, *, plots: bool = True) -> dict[str, Any]:
    """Write every output of ``report`` into ``out_dir`` atomically
    (:func:`mechkin.io.report.write_report`); return the final summary."""
    from mechkin.io.report import write_report as _write

    return _write(report, out_dir, plots=plots)
