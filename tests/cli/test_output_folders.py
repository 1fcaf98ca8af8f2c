"""Outputs that are always whole (issue: reliability): the output folder is checked before any
work, locked while a run writes, replaced completely by a rerun, and a signal at any moment
leaves no staging folder, no process, and either the previous or the complete new outputs."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
FK = ROOT / "scenarios" / "kim1995_direct_drive_fk.yaml"
PUMA = ROOT / "scenarios" / "puma560_wave_fk.yaml"


def _env(tmp_path: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.update(PYTHONPATH=str(ROOT), MPLBACKEND="Agg", MECHKIN_JIT="0",
               NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    return env


def _mechkin(tmp_path: Path, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mechkin", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=tmp_path, env=_env(tmp_path))


def _visible(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir())


def test_rerun_without_plots_replaces_the_folder(tmp_path):
    out = tmp_path / "o"
    assert _mechkin(tmp_path, "fk", str(FK), "--out", str(out)).returncode == 0
    assert "stick.png" in _visible(out)
    r = _mechkin(tmp_path, "fk", str(FK), "--out", str(out), "--no-plots")
    assert r.returncode == 0, r.stderr
    assert _visible(out) == ["fk.csv", "fk.layout.json", "fk.mcap", "summary.json"]


def test_another_scenarios_folder_is_refused_unless_forced(tmp_path):
    out = tmp_path / "o"
    assert _mechkin(tmp_path, "fk", str(FK), "--out", str(out), "--no-plots").returncode == 0
    before = (out / "fk.csv").read_bytes()
    r = _mechkin(tmp_path, "fk", str(PUMA), "--out", str(out), "--no-plots")
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "kim1995_direct_drive_fk" in r.stderr
    assert (out / "fk.csv").read_bytes() == before
    r = _mechkin(tmp_path, "fk", str(PUMA), "--out", str(out), "--no-plots", "--force")
    assert r.returncode == 0, r.stderr
    assert json.loads((out / "summary.json").read_text())["scenario"] == "puma560_wave_fk"


@pytest.mark.parametrize("kind", ["file", "long", "foreign"])
def test_unusable_out_is_refused_before_any_work(tmp_path, kind):
    if kind == "file":
        out = tmp_path / "afile"
        out.write_text("x")
    elif kind == "long":
        out = tmp_path / ("n" * 300)
    else:
        out = tmp_path / "notes"
        out.mkdir()
        (out / "mine.txt").write_text("keep")
    t0 = time.perf_counter()
    r = _mechkin(tmp_path, "fk", str(PUMA), "--out", str(out), "--no-plots")
    assert r.returncode == 2
    assert "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "--out" in r.stderr
    assert time.perf_counter() - t0 < 60  # before the 201-step solve, not after
    if kind == "foreign":
        assert _visible(out) == ["mine.txt"]


_HOLD = """
import sys, time
from mechkin.io.report import prepare_output
with prepare_output(sys.argv[1], sys.argv[2]):
    print("held", flush=True)
    time.sleep(120)
"""


def _hold_lock(tmp_path: Path, out: Path, scenario: str) -> subprocess.Popen:
    holder = subprocess.Popen([sys.executable, "-c", _HOLD, str(out), scenario],
                              stdout=subprocess.PIPE, text=True, env=_env(tmp_path))
    assert holder.stdout.readline().strip() == "held"
    return holder


def test_a_held_lock_refuses_a_second_run(tmp_path):
    """A live run holds the lock: a second run is refused and leaves the lock alone, so a
    third run is refused too (issue 28 item 2: the refused run deleted the lock)."""
    out = tmp_path / "o"
    holder = _hold_lock(tmp_path, out, "kim1995_direct_drive_fk")
    try:
        for _ in range(2):
            r = _mechkin(tmp_path, "fk", str(FK), "--out", str(out), "--no-plots")
            assert r.returncode == 2 and f"pid {holder.pid}" in r.stderr, r.stderr
            assert len(r.stderr.strip().splitlines()) == 1
            assert (out / ".mechkin.lock").read_text().strip() == str(holder.pid)
    finally:
        holder.kill()
        holder.communicate()
    # the holder is gone (SIGKILL: its lock file stays, the kernel dropped its flock)
    assert (out / ".mechkin.lock").exists()
    r = _mechkin(tmp_path, "fk", str(FK), "--out", str(out), "--no-plots")
    assert r.returncode == 0, r.stderr
    assert not (out / ".mechkin.lock").exists()


def test_a_lock_file_with_a_live_pid_but_no_holder_is_taken_over(tmp_path):
    """The pid in the file is only for the message: a lock nobody holds (its run was killed
    and the pid reused) does not block the folder forever."""
    out = tmp_path / "o"
    out.mkdir()
    (out / ".mechkin.lock").write_text(f"{os.getpid()}\n")
    r = _mechkin(tmp_path, "fk", str(FK), "--out", str(out), "--no-plots")
    assert r.returncode == 0, r.stderr
    assert not (out / ".mechkin.lock").exists()


def _leftovers(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob(".mechkin-*"))


TRACK = ROOT / "scenarios" / "park_conveyor_torque.yaml"


@pytest.mark.parametrize("task,scenario", [("fk", PUMA), ("track", TRACK)])
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_at_random_moments_leaves_previous_or_complete_outputs(tmp_path, sig, task,
                                                                      scenario):
    out = tmp_path / "o"
    r = _mechkin(tmp_path, task, str(scenario), "--out", str(out))
    assert r.returncode == 0, r.stderr
    old = {p.name: p.read_bytes() for p in out.iterdir()}
    rng = random.Random(sig)
    for _ in range(3):
        proc = subprocess.Popen([sys.executable, "-m", "mechkin", task, str(scenario), "--out",
                                 str(out)], cwd=tmp_path, env=_env(tmp_path),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(rng.uniform(0.5, 6.0))
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
        assert "Traceback" not in err
        assert proc.returncode in (0, 130, 143, -sig), (proc.returncode, err)
        assert _leftovers(tmp_path) == []
        now = {p.name: p.read_bytes() for p in out.iterdir()}
        assert set(now) == set(old)
        s = json.loads(now["summary.json"])
        assert s["status"] == "ok" and set(s["files"]) == set(old)
        old = now


def _can_mount_tmpfs(where: Path, size: str = "64m") -> bool:
    where.mkdir(parents=True, exist_ok=True)
    try:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                           capture_output=True, timeout=20)
    except (OSError, subprocess.SubprocessError):
        return False
    return r.returncode == 0


def test_out_on_a_mount_point_works(tmp_path):
    """--out is itself a mount point (a tmpfs, like a container volume): staging happens inside
    it, so the renames never cross file systems."""
    mnt = tmp_path / "mnt"
    if not _can_mount_tmpfs(mnt):
        pytest.skip("cannot mount a tmpfs here (needs root or CAP_SYS_ADMIN)")
    try:
        r = _mechkin(tmp_path, "fk", str(FK), "--out", str(mnt), "--no-plots")
        assert r.returncode == 0, r.stderr
        assert _visible(mnt) == ["fk.csv", "fk.layout.json", "fk.mcap", "summary.json"]
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True, timeout=20)


def _children_of(pid: int) -> list[int]:
    out = []
    for p in Path("/proc").iterdir():
        if p.name.isdigit():
            try:
                stat = (p / "stat").read_text()
            except OSError:
                continue
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            if ppid == pid:
                out.append(int(p.name))
    return out


def test_sigterm_stops_a_two_worker_sweep(tmp_path):
    """SIGTERM to the main process of a --workers 2 design sweep: the workers are stopped with
    it, no staging folder is left, nothing is written."""
    out = tmp_path / "o"
    sc = ROOT / "scenarios" / "lee_design_sweep_r.yaml"
    proc = subprocess.Popen([sys.executable, "-m", "mechkin", "workspace", str(sc), "--out",
                             str(out), "--workers", "2", "--no-plots"], cwd=tmp_path,
                            env=_env(tmp_path), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    kids: list[int] = []
    t0 = time.time()
    while time.time() - t0 < 90 and proc.poll() is None:
        kids = _children_of(proc.pid)
        if len(kids) >= 2:
            break
        time.sleep(0.2)
    if proc.poll() is not None:
        pytest.skip("the sweep finished before its workers could be seen")
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode in (143, -signal.SIGTERM), (proc.returncode, err)
    assert "Traceback" not in err
    time.sleep(1.0)
    alive = [k for k in kids if Path(f"/proc/{k}").exists()
             and "Z" not in Path(f"/proc/{k}/stat").read_text().rsplit(")", 1)[1].split()[0]]
    assert alive == [], f"worker processes left: {alive}"
    assert _leftovers(tmp_path) == []
    assert not out.exists() or _visible(out) == []


def test_a_full_disk_is_exit_4_and_keeps_the_previous_run(tmp_path):
    """A tmpfs that holds the small run but not the large one (issue 28 item 6: exit 3)."""
    mnt = tmp_path / "mnt"
    if not _can_mount_tmpfs(mnt, "192k"):
        pytest.skip("cannot mount a tmpfs here (needs root or CAP_SYS_ADMIN)")
    try:
        out = mnt / "o"
        r = _mechkin(tmp_path, "fk", str(FK), "--out", str(out), "--no-plots")
        assert r.returncode == 0, r.stderr
        before = {p.name: p.read_bytes() for p in out.iterdir()}
        r = _mechkin(tmp_path, "fk", str(PUMA), "--out", str(out), "--force")
        assert r.returncode == 4, r.stderr
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and "No space left" in lines[0] and str(out) in lines[0]
        assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True, timeout=20)


def _descendants(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        kids = _children_of(todo.pop())
        out.extend(kids)
        todo.extend(kids)
    return out


def _alive(pids: list[int]) -> list[int]:
    alive = []
    for k in pids:
        try:
            state = Path(f"/proc/{k}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            alive.append(k)
    return alive


def test_sigkill_of_mechkin_takes_its_workers_with_it(tmp_path):
    """SIGKILL to the main process of a --workers 2 sweep (no handler runs): the forkserver
    sees its parent gone and the kernel stops the workers (PR_SET_PDEATHSIG), so no worker
    outlives the run (issue 28 item 5: both workers were found alive 19 minutes later)."""
    out = tmp_path / "o"
    sc = ROOT / "scenarios" / "lee_design_sweep_r.yaml"
    proc = subprocess.Popen([sys.executable, "-m", "mechkin", "workspace", str(sc), "--out",
                             str(out), "--workers", "2", "--no-plots"], cwd=tmp_path,
                            env=_env(tmp_path), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    kids: list[int] = []
    t0 = time.time()
    while time.time() - t0 < 90 and proc.poll() is None:
        kids = _descendants(proc.pid)
        if len(kids) >= 3:  # the forkserver and two workers
            break
        time.sleep(0.2)
    if proc.poll() is not None:
        pytest.skip("the sweep finished before its workers could be seen")
    time.sleep(0.5)
    kids = _descendants(proc.pid)
    proc.kill()
    proc.wait(timeout=30)
    deadline = time.time() + 20
    while _alive(kids) and time.time() < deadline:
        time.sleep(0.2)
    left = _alive(kids)
    for k in left:  # do not leak them into the next test
        os.kill(k, signal.SIGKILL)
    assert left == [], f"worker processes left: {left}"


def test_a_signal_while_a_new_folder_is_written_leaves_it_whole_or_absent(tmp_path):
    """SIGTERM at random moments of a first run into a new --out: afterwards the folder is
    absent or holds the complete run, never an empty folder (issue 28 item 5)."""
    rng = random.Random(5)
    for k in range(3):
        out = tmp_path / f"o{k}"
        proc = subprocess.Popen([sys.executable, "-m", "mechkin", "fk", str(PUMA), "--out",
                                 str(out)], cwd=tmp_path, env=_env(tmp_path),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(rng.uniform(1.0, 6.0))
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
        assert "Traceback" not in err
        assert _leftovers(tmp_path) == []
        if out.exists():
            names = set(_visible(out))
            s = json.loads((out / "summary.json").read_text())
            assert names == set(s["files"]) and s["status"] == "ok", names
