"""The files of ``mechkin run``: a JUnit XML report and an aggregate JSON summary for CI.

JUnit layout (the schema CI servers read: Jenkins, GitLab, GitHub test reporters)::

    <testsuites name="mechkin run" tests= failures= errors= time=>
      <testsuite name="mechkin run" tests= failures= errors= skipped="0" time= timestamp=
                 hostname=>
        <properties>  exit codes: <property name="exit code 5" value="an expect: ..."/>,
                      estimates: <property name="estimated_time_s <scenario>" value="2.1"/>
        <testcase classname="<file stem>" name="<scenario> (task)" file= time=>
          <failure type="exit 1" message=...> or <error type="exit 2|3|4" message=...>
        <testcase classname="<file stem>" name="expect <key>">  one per expect: entry
          <failure type="expect" message="key: value V, expected E +- tol T (unit)"/>

Every file is written atomically (:mod:`mechkin.io.atomic`). The inputs are the plain records
of :func:`mechkin.cli.run_many.run_one` (dicts).
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from mechkin.errors import EXIT_CODES, OutputDirError
from mechkin.io.atomic import atomic_write_text

_KIND = {1: "solver result not ok", 2: "bad input", 3: "internal error", 4: "output error",
         5: "expect failed"}


def check_target(path: Path, option: str) -> None:
    """Refuse a report file that cannot be written, before any work (exit 2)."""
    parent = path.absolute().parent
    if path.is_dir():
        raise OutputDirError(f"{option} {path}: expected a file name, got a folder")
    if not parent.is_dir():
        raise OutputDirError(f"{option} {path}: the folder {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise OutputDirError(f"{option} {path}: the folder {parent} is not writable")


def expect_message(c: dict[str, Any]) -> str:
    """``key: value V, expected E +- T (unit)`` or ``key: value V, expected in [lo, hi]``."""
    if c.get("message") and c.get("actual") is None:
        return f"{c['key']}: {c['message']}"
    unit = c.get("unit", "SI")
    if unit == "word":
        return f"{c['key']}: value {c.get('actual')!r}, expected {c.get('expected')!r}"
    if "expected" in c:
        want = f"expected {c['expected']} +- tolerance {c.get('tol')} ({unit})"
    else:
        want = f"expected in [{c.get('min')}, {c.get('max')}] ({unit})"
    extra = f"; {c['message']}" if c.get("message") else ""
    return f"{c['key']}: value {c.get('actual')}, {want}{extra}"


def junit_xml(results: list[dict[str, Any]], total_s: float) -> str:
    """The JUnit XML text of a ``mechkin run`` (see the module docstring)."""
    suite = ET.Element("testsuite", name="mechkin run")
    props = ET.SubElement(suite, "properties")
    for code, what in EXIT_CODES.items():
        ET.SubElement(props, "property", name=f"exit code {code}", value=what)
    n = failures = errors = 0
    for r in results:
        cls = Path(r["path"]).stem
        case = ET.SubElement(suite, "testcase", classname=cls,
                             name=f"{r['name']} ({r['task'] or 'scenario'})", file=r["path"],
                             time=f"{r['time_s']:.3f}")
        n += 1
        code = r["code"]
        if code:
            text = "\n".join(r["errors"] + r["messages"]) or r["line"] or str(r["status"])
            first = (r["errors"] or r["messages"] or [r["line"] or str(r["status"])])[0]
            kind = _KIND.get(code, "stopped by a signal")
            tag = "failure" if code in (1, 5) else "error"
            el = ET.SubElement(case, tag, type=f"exit {code}: {kind}",
                               message=f"exit {code} ({kind}): {first}"[:1000])
            el.text = text
            if tag == "failure":
                failures += 1
            else:
                errors += 1
        est = r.get("estimated_time_s")
        if est is not None:  # the estimate made before the run (a testcase has no properties)
            ET.SubElement(props, "property", name=f"estimated_time_s {r['name']}",
                          value=f"{est:g}")
        if r["out_dir"]:
            ET.SubElement(case, "system-out").text = (
                f"{r['line']}\noutputs: {r['out_dir']}"
                + (f"\nestimated time: {est:g} s" if est is not None else ""))
        for c in r["checks"]:
            n += 1
            ec = ET.SubElement(suite, "testcase", classname=cls, name=f"expect {c['key']}",
                               file=r["path"], time="0")
            if not c.get("ok"):
                failures += 1
                msg = expect_message(c)
                el = ET.SubElement(ec, "failure", type="exit 5: expect failed", message=msg)
                el.text = msg + (f"\nsource: {c['source']}" if c.get("source") else "")
    attrs = {"tests": str(n), "failures": str(failures), "errors": str(errors), "skipped": "0",
             "time": f"{total_s:.3f}",
             "timestamp": time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime()),
             "hostname": socket.gethostname() or "localhost"}
    for k, v in attrs.items():
        suite.set(k, v)
    root = ET.Element("testsuites", name="mechkin run", tests=str(n), failures=str(failures),
                      errors=str(errors), time=f"{total_s:.3f}")
    root.append(suite)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def write_junit(path: Path, results: list[dict[str, Any]], total_s: float) -> Path:
    return atomic_write_text(path, junit_xml(results, total_s))


def batch_summary(results: list[dict[str, Any]], total_s: float, code: int) -> dict[str, Any]:
    """The aggregate of a ``mechkin run``: counts, exit code, times (``estimated_time_s``: the
    sum of the scenarios' estimates), and per scenario its path, task, exit code, status, time,
    estimated time (null when its task made none, e.g. refused), output folder, problem lines
    and expect results."""
    checks = [c for r in results for c in r["checks"]]
    by: dict[str, int] = {}
    for r in results:
        by[str(r["code"])] = by.get(str(r["code"]), 0) + 1
    return {
        "exit_code": code,
        "exit_codes": {str(k): v for k, v in EXIT_CODES.items()},
        "n_scenarios": len(results),
        "n_passed": sum(r["code"] == 0 for r in results),
        "by_exit_code": by,
        "n_expects": len(checks),
        "n_expects_held": sum(1 for c in checks if c.get("ok")),
        "time_s": round(total_s, 3),
        "estimated_time_s": float(f"{sum(r.get('estimated_time_s') or 0.0 for r in results):.3g}"),
        "scenarios": [{"path": r["path"], "name": r["name"], "task": r["task"],
                       "exit_code": r["code"], "status": r["status"],
                       "time_s": round(r["time_s"], 3),
                       "estimated_time_s": r.get("estimated_time_s"), "out_dir": r["out_dir"],
                       "errors": r["errors"], "messages": r["messages"],
                       "expect": r["checks"]} for r in results],
    }


def write_summary(path: Path, results: list[dict[str, Any]], total_s: float, code: int) -> Path:
    text = json.dumps(_finite(batch_summary(results, total_s, code)), indent=2,
                      default=_plain, allow_nan=False)
    return atomic_write_text(path, text + "\n")


def _finite(obj: Any) -> Any:
    """NaN and infinities (never valid JSON) as null."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


def _plain(obj: Any) -> Any:
    if hasattr(obj, "tolist"):
        return obj.tolist()
    if isinstance(obj, float):
        return None
    return str(obj)
