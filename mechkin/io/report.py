"""Report records -> files: one entry point for every task (DESIGN.md: io).

:func:`write_report` stages every file of a run in one :class:`~mechkin.io.output_dir.OutputDir`
and hands the report's task record to its writer module ``mechkin.io.<writer>_out`` (function
``write(od, report, plots)``), then writes summary.json with ``out_dir`` and ``files``.

Imports: records (types only), io.atomic and the writer modules (loaded by name).
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

from mechkin.io.output_dir import OutputDir
from mechkin.records import Report


def write_report(report: Report, out_dir: str | Path, *, plots: bool = True) -> dict[str, Any]:
    """Write every output of ``report`` into ``out_dir`` atomically; return the final summary.

    ``plots=False`` (``--no-plots``) skips the PNGs even when the scenario asks for them.
    """
    out_dir = Path(out_dir)
    writer = importlib.import_module(f"mechkin.io.{report.writer}_out")
    summary = dict(report.summary)
    summary["out_dir"] = str(out_dir)
    with OutputDir(out_dir) as od:
        writer.write(od, report, plots)
        summary["files"] = od.files + ["summary.json"]
        od.write_json("summary.json", summary)
    return summary
