"""Run every bundled scenario into a folder, or compare two such folders byte by byte.

On demand (not collected by pytest): the check that a move or split of modules changed no
output. Run the tree before the change and after it, then compare::

    PYTHONPATH=. python tests/architecture/compare_outputs.py run /tmp/before
    # ... move, split ...
    PYTHONPATH=. python tests/architecture/compare_outputs.py run /tmp/after
    python tests/architecture/compare_outputs.py compare /tmp/before /tmp/after

``run`` calls ``python -m mechkin <task> FILE --out DIR/<name>`` for every ``scenarios/*.yaml``
(the task read from the file's ``task:`` line) with the code on ``PYTHONPATH`` (``--root`` picks
another checkout) and records each exit code in ``DIR/exit_codes.json``. ``compare`` checks
that both trees hold the same files and that every file's bytes are equal, except
``summary.json``, compared as JSON with run-time fields (the output folder, wall-clock
timings: ``RUNTIME_KEY``) left out. Exit 0
when identical, 1 with one line per difference otherwise.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# run-time fields of summary.json, not results: the output folder and wall-clock measurements
# (time_s, solve_time_s, compute_time_s, rates_time_s, time_per_step_s,
# median_time_per_target_s); results such as t_s, t_a_s, t_f_s, duration_s are compared
RUNTIME_KEY = re.compile(r"^(out_dir|time_s)$|_time_s$|(^|_)time_per_\w+_s$")


def _task(path: Path) -> str:
    for line in path.read_text(encoding="utf-8").splitlines():
        m = re.match(r"task:\s*(\w+)", line)
        if m:
            return m.group(1)
    raise SystemExit(f"{path}: no 'task:' line")


def run(dest: Path, root: Path, only: str | None) -> int:
    dest.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PYTHONPATH=str(root))
    codes = {}
    for f in sorted((root / "scenarios").glob("*.yaml")):
        if only and not re.search(only, f.stem):
            continue
        cmd = [sys.executable, "-m", "mechkin", _task(f), str(f), "--out", str(dest / f.stem)]
        p = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True)
        codes[f.stem] = p.returncode
        print(f"{p.returncode} {f.stem}", flush=True)
        if p.returncode not in (0, 1):
            print(p.stderr[-2000:], file=sys.stderr)
    (dest / "exit_codes.json").write_text(json.dumps(codes, indent=1, sort_keys=True))
    return 0


def _strip(obj):
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if not RUNTIME_KEY.search(k)}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def _diff_json(a, b, path="") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{path}.{k}: only in {'after' if k in b else 'before'}")
            else:
                out += _diff_json(a[k], b[k], f"{path}.{k}")
        return out
    if a != b:
        return [f"{path}: {str(a)[:60]} != {str(b)[:60]}"]
    return []


def compare(a: Path, b: Path) -> int:
    fa = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    fb = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    problems = [f"only in {a}: {p}" for p in sorted(fa - fb)]
    problems += [f"only in {b}: {p}" for p in sorted(fb - fa)]
    n = 0
    for rel in sorted(fa & fb):
        n += 1
        x, y = (a / rel).read_bytes(), (b / rel).read_bytes()
        if x == y:
            continue
        if rel.name == "summary.json":
            d = _diff_json(_strip(json.loads(x)), _strip(json.loads(y)))
            problems += [f"{rel}: {line}" for line in d]
        else:
            problems.append(f"{rel}: bytes differ")
    for line in problems:
        print(line)
    print(f"{n} files compared, {len(problems)} differences")
    return 1 if problems else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run every bundled scenario into DEST")
    r.add_argument("dest", type=Path)
    r.add_argument("--root", type=Path, default=ROOT, help="checkout whose code and scenarios run")
    r.add_argument("--only", help="regular expression on scenario names")
    c = sub.add_parser("compare", help="compare two output trees")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    args = ap.parse_args(argv)
    if args.cmd == "run":
        return run(args.dest.resolve(), args.root.resolve(), args.only)
    return compare(args.before, args.after)


if __name__ == "__main__":
    sys.exit(main())
