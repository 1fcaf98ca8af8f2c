"""The commit protocol of an output folder (issue 28 items 1 and 3): a SIGKILL at every step of
a commit leaves the previous run whole, the new run whole, or a folder without summary.json
that holds the commit marker; never one run's tables with another run's summary. The next run
repairs it. Nothing that mechkin did not create is removed, replaced or followed."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from mechkin.errors import OutputDirError
from mechkin.io.output_dir import COMMIT_MARKER, OutputDir
from mechkin.io.report import previous_files

ROOT = Path(__file__).resolve().parents[2]

# one run: files tagged with the run's name, summary.json last, like io.report.write_report
_RUN = """
import os, signal, sys
from mechkin.io import output_dir
from mechkin.io.output_dir import OutputDir
from mechkin.io.report import previous_files

out, tag, kill_at, names = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4].split(",")
calls = [0]
def counted(fn):
    def wrapper(*a, **k):
        calls[0] += 1
        if calls[0] == kill_at:
            os.kill(os.getpid(), signal.SIGKILL)
        return fn(*a, **k)
    return wrapper
commit = OutputDir._commit
def patched(self, staging):
    os.replace, os.unlink = counted(os.replace), counted(os.unlink)
    return commit(self, staging)
OutputDir._commit = patched
with OutputDir(out, replaces=previous_files(__import__("pathlib").Path(out)),
               scenario="s") as od:
    for n in names:
        od.write_text(n, tag + ":" + n)
    od.write_json("summary.json", {"scenario": "s", "run": tag,
                                   "files": od.files + ["summary.json"]})
print(calls[0])
"""


def _run(out: Path, tag: str, names: list[str], kill_at: int = 0) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", _RUN, str(out), tag, str(kill_at),
                           ",".join(names)], capture_output=True, text=True, timeout=60,
                          env=env)


def _files(out: Path) -> set[str]:
    rel = (p.relative_to(out) for p in out.rglob("*") if p.is_file())
    return {str(r) for r in rel if not any(part.startswith(".") for part in r.parts)}


def _check_whole_or_marked(out: Path) -> str:
    """'whole:<tag>' for a folder of exactly one run, 'marked' for an interrupted commit."""
    summary = out / "summary.json"
    if not summary.exists():
        assert (out / COMMIT_MARKER).is_file(), sorted(_files(out))
        return "marked"
    s = json.loads(summary.read_text())
    tag = s["run"]
    assert _files(out) == set(s["files"]), (sorted(_files(out)), s["files"])
    for name in s["files"]:
        if name != "summary.json":
            assert (out / name).read_text() == f"{tag}:{name}", (name, tag)
    return f"whole:{tag}"


def test_sigkill_at_every_step_of_a_commit(tmp_path):
    old = ["a.csv", "b.png", "sub/c.csv"]
    new = ["a.csv", "d.csv", "sub/c.csv"]
    out = tmp_path / "o"
    assert _run(out, "A", old).returncode == 0
    shutil.copytree(out, tmp_path / "A")
    r = _run(out, "B", new)
    assert r.returncode == 0, r.stderr
    steps = int(r.stdout)  # mutating calls of B's commit over A (renames, removals)
    assert steps >= 8
    seen = set()
    for k in range(1, steps + 2):
        d = tmp_path / f"k{k}"
        shutil.copytree(tmp_path / "A", d)
        r = _run(d, "B", new, kill_at=k)
        assert r.returncode in (0, -signal.SIGKILL), r.stderr
        state = _check_whole_or_marked(d)
        seen.add(state)
        # the next run repairs whatever was left: exactly its own files, no marker
        r = _run(d, "C", ["a.csv", "e.csv"])
        assert r.returncode == 0, r.stderr
        assert _check_whole_or_marked(d) == "whole:C"
        assert not (d / COMMIT_MARKER).exists()
        assert _files(d) == {"a.csv", "e.csv", "summary.json"}
        assert sorted(p.name for p in d.iterdir() if p.name.startswith(".")) == []
    assert {"whole:A", "marked", "whole:B"} <= seen


def test_a_symlinked_subfolder_is_never_followed(tmp_path):
    """A previous summary lists sub/x and out/sub is a symlink: the target's files are not
    deleted, and no new file is written through it (item 1)."""
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "x").write_text("keep")
    out = tmp_path / "o"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"scenario": "s", "files": ["sub/x",
                                                                            "summary.json"]}))
    (out / "sub").symlink_to(victim)
    with OutputDir(out, replaces=previous_files(out)) as od:
        od.write_text("a.csv", "1")
        od.write_json("summary.json", {"files": od.files + ["summary.json"]})
    assert (victim / "x").read_text() == "keep"
    assert (out / "sub").is_symlink()
    with pytest.raises(OutputDirError, match="symlink"), OutputDir(out) as od:
        od.write_text("sub/y.csv", "1")
    assert sorted(p.name for p in victim.iterdir()) == ["x"]


def test_a_symlink_or_fifo_at_a_destination_is_refused(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    target = tmp_path / "elsewhere.csv"
    target.write_text("keep")
    (out / "a.csv").symlink_to(target)
    os.mkfifo(out / "b.csv")
    for name in ("a.csv", "b.csv"):
        with pytest.raises(OutputDirError, match=name), OutputDir(out) as od:
            od.write_text(name, "new")
    assert target.read_text() == "keep" and (out / "a.csv").is_symlink()
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", "b.csv"]


def test_replaces_never_removes_special_files_or_folders(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    os.mkfifo(out / "f")
    (out / "d").mkdir()
    (out / "old.csv").write_text("x")
    with OutputDir(out, replaces=["f", "d", "old.csv", "../o/old.csv"]) as od:
        od.write_text("a.csv", "1")
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", "d", "f"]
