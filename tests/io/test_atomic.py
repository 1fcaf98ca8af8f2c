"""Atomic writes: a failure never leaves a partial file or a half-filled output folder."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from mechkin.errors import OutputError
from mechkin.io.atomic import atomic_path, atomic_write_bytes, atomic_write_text
from mechkin.io.output_dir import OutputDir


def _names(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir())


def test_atomic_write_text_and_bytes(tmp_path: Path) -> None:
    p = atomic_write_text(tmp_path / "sub" / "a.txt", "héllo\n")
    assert p.read_text(encoding="utf-8") == "héllo\n"
    atomic_write_bytes(p, b"\x00\x01")
    assert p.read_bytes() == b"\x00\x01"
    assert _names(p.parent) == ["a.txt"]


def test_atomic_path_keeps_suffix_and_renames(tmp_path: Path) -> None:
    final = tmp_path / "plot.png"
    with atomic_path(final) as tmp:
        assert tmp.parent == tmp_path
        assert tmp.suffix == ".png" and tmp.name.startswith(".")
        assert not final.exists()
        tmp.write_bytes(b"png")
    assert final.read_bytes() == b"png"
    assert _names(tmp_path) == ["plot.png"]


def test_failing_writer_leaves_old_content_and_no_temp(tmp_path: Path) -> None:
    final = tmp_path / "table.csv"
    final.write_text("old\n")
    with pytest.raises(RuntimeError, match="boom"), atomic_path(final) as tmp:
        tmp.write_text("half a fi")
        raise RuntimeError("boom")
    assert final.read_text() == "old\n"
    assert _names(tmp_path) == ["table.csv"]


def test_failing_writer_on_new_file_leaves_nothing(tmp_path: Path) -> None:
    with (pytest.raises(ZeroDivisionError), atomic_path(tmp_path / "new.bin") as tmp,
          open(tmp, "wb") as f):
        f.write(b"x" * 1000)
        _ = 1 / 0
    assert _names(tmp_path) == []


def test_file_permissions_follow_umask(tmp_path: Path) -> None:
    p = atomic_write_text(tmp_path / "a.txt", "x")
    umask = os.umask(0)
    os.umask(umask)
    assert p.stat().st_mode & 0o777 == 0o666 & ~umask


def test_output_dir_commits_on_success(tmp_path: Path) -> None:
    out = tmp_path / "runs" / "demo"
    with OutputDir(out) as od:
        od.write_text("notes.txt", "a\n")
        od.write_csv("tables/q.csv", {"t_s": np.array([0.0, 0.5]), "q1_rad": [0.1, 0.2]})
        od.path_for("blob.bin").write_bytes(b"\x01")
        # staged inside the folder (same file system even on a mount point), nothing final yet
        assert [p.name for p in out.iterdir()] == [od.staging.name]
        od.write_json("summary.json", {"files": od.files})
    assert od.files == ["notes.txt", "tables/q.csv", "blob.bin", "summary.json"]
    assert json.loads((out / "summary.json").read_text())["files"] == od.files[:3]
    assert (out / "tables" / "q.csv").read_text().startswith("t_s,q1_rad\n")
    assert _names(tmp_path / "runs") == ["demo"]  # staging dir removed


def test_output_dir_exception_leaves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    with pytest.raises(ValueError, match="solver"), OutputDir(out) as od:
        od.write_text("a.csv", "t_s\n0\n")
        od.path_for("b.png").write_bytes(b"partial")
        raise ValueError("solver blew up")
    assert not out.exists()
    assert _names(tmp_path) == []


def test_output_dir_exception_keeps_previous_run(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    with OutputDir(out) as od:
        od.write_text("a.csv", "old\n")
    with pytest.raises(OutputError), OutputDir(out) as od:
        od.write_text("a.csv", "new\n")
        od.write_csv("bad.csv", {"x_m": np.array([np.nan])})
    assert (out / "a.csv").read_text() == "old\n"
    assert _names(out) == ["a.csv"]
    assert _names(tmp_path) == ["demo"]


def test_output_dir_requested_but_unwritten_file_is_an_error(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    with pytest.raises(OutputError, match="never written"), OutputDir(out) as od:
        od.write_text("a.txt", "a")
        od.path_for("missing.png")
    assert not out.exists()


@pytest.mark.parametrize("name", ["/abs.txt", "../up.txt", "a/../../b.txt", ""])
def test_output_dir_refuses_escaping_names(tmp_path: Path, name: str) -> None:
    with OutputDir(tmp_path / "demo") as od, pytest.raises(OutputError, match="relative path"):
        od.path_for(name)


def test_output_dir_outside_with_block(tmp_path: Path) -> None:
    od = OutputDir(tmp_path / "demo")
    with pytest.raises(OutputError, match="outside"):
        od.path_for("a.txt")


def test_output_dir_onto_existing_file(tmp_path: Path) -> None:
    (tmp_path / "demo").write_text("x")
    with pytest.raises(OutputError, match="expected a directory"), OutputDir(tmp_path / "demo"):
        pass


def test_output_dir_replaces_the_previous_runs_files(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    with OutputDir(out) as od:
        od.write_text("a.csv", "1\n")
        od.write_text("plot.png", "png")
    with OutputDir(out, replaces=["a.csv", "plot.png", "../evil"]) as od:
        od.write_text("a.csv", "2\n")
    assert _names(out) == ["a.csv"] and (out / "a.csv").read_text() == "2\n"
    assert _names(tmp_path) == ["demo"]


def test_output_dir_sweeps_stale_staging_of_dead_runs(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    out.mkdir()
    stale = out / ".mechkin-staging-999999999-abc"
    stale.mkdir()
    (stale / "x.csv").write_text("x")
    mine = out / f".mechkin-staging-{os.getpid()}-keep"
    mine.mkdir()
    with OutputDir(out) as od:
        od.write_text("a.csv", "1\n")
    assert not stale.exists() and mine.exists()


@pytest.mark.parametrize("kind", ["fifo", "device", "symlink", "folder"])
def test_atomic_write_never_replaces_a_special_file(tmp_path: Path, kind: str) -> None:
    """``import -o`` / ``export -o`` at a device, FIFO, symlink or folder: refused (exit 2),
    the thing itself left as it was (issue 28 item 1: ``-o /dev/null`` replaced it)."""
    from mechkin.errors import OutputDirError

    target = tmp_path / "t"
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "device":
        try:
            os.mknod(target, 0o600 | __import__("stat").S_IFCHR, os.makedev(1, 3))
        except PermissionError:
            pytest.skip("mknod needs CAP_MKNOD")
    elif kind == "symlink":
        target.symlink_to(victim)
    else:
        target.mkdir()
    before = os.lstat(target)
    with pytest.raises(OutputDirError, match="exists and is a") as e:
        atomic_write_text(target, "new")
    assert e.value.exit_code == 2
    after = os.lstat(target)
    assert (after.st_ino, after.st_mode) == (before.st_ino, before.st_mode)
    assert victim.read_text() == "keep"
    assert _names(tmp_path) == ["t", "victim.txt"]


def test_disk_full_while_staging_is_exit_4_and_keeps_the_previous_run(tmp_path: Path,
                                                                       monkeypatch) -> None:
    """ENOSPC from a writer inside the output folder -> OutputError (exit 4), the previous
    files untouched, no staging left (issue 28 item 6)."""
    import errno

    out = tmp_path / "o"
    with OutputDir(out) as od:
        od.write_text("a.csv", "old")
    real = Path.write_bytes

    def full(self, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Path, "write_bytes", full)
    with pytest.raises(OutputError, match="No space left") as e, OutputDir(out) as od:
        od.write_text("a.csv", "new")
    monkeypatch.setattr(Path, "write_bytes", real)
    assert e.value.exit_code == 4
    assert _names(out) == ["a.csv"] and (out / "a.csv").read_text() == "old"
