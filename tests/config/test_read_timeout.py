"""A read that stalls gives up after a bounded time with one line (issue 28): a pipe whose
writer wrote a few bytes and stopped, and a scenario file whose reads hang (a hung NFS or FUSE
mount, simulated by a read that sleeps) both end in one ConfigError line naming the file,
exit 2, within a few times MECHKIN_READ_TIMEOUT."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pytest

from mechkin.cli import shell
from mechkin.config import guarded_read
from mechkin.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_pipe_whose_writer_stalls_gives_up(tmp_path):
    fifo = tmp_path / "scenario.yaml"
    os.mkfifo(fifo)
    fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    release = threading.Event()

    def writer() -> None:
        w = os.open(fifo, os.O_WRONLY)
        os.write(w, b"name: x\n")
        release.wait(30)  # holds the pipe open without writing: the read stalls
        os.close(w)

    th = threading.Thread(target=writer, daemon=True)
    th.start()
    t0 = time.perf_counter()
    try:
        with pytest.raises(ConfigError) as exc:
            guarded_read._read_fd(fd, fifo, what="scenario file", limit=1 << 20, timeout=0.5)
    finally:
        release.set()
        th.join(10)
    assert time.perf_counter() - t0 < 10
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1 and len(msg) <= 300, msg
    assert msg.startswith(f"{fifo}: reading the scenario file stalled")
    assert "after 8 bytes" in msg and "MECHKIN_READ_TIMEOUT" in msg


def test_a_scenario_whose_reads_hang_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    sc = tmp_path / "stall.yaml"
    sc.write_text((ROOT / "scenarios" / "five_bar_fk.yaml").read_text())
    real_read = os.read

    def hanging_read(fd: int, n: int) -> bytes:
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            target = ""
        if target.endswith("stall.yaml"):
            time.sleep(3.0)  # the mount does not answer
            return b""
        return real_read(fd, n)

    if not Path("/proc/self/fd").is_dir():
        pytest.skip("needs /proc/self/fd")
    monkeypatch.setenv("MECHKIN_READ_TIMEOUT", "0.5")
    monkeypatch.setattr(guarded_read.os, "read", hanging_read)
    t0 = time.perf_counter()
    with pytest.raises(shell.Exit) as code:
        shell.execute("fk", sc, tmp_path / "o", False, False, lambda s: s["status"])
    assert time.perf_counter() - t0 < 10
    err = capsys.readouterr().err.strip().splitlines()
    assert code.value.code == 2 and len(err) == 1 and len(err[0]) <= 300, err
    assert err[0].startswith(f"{sc}: reading the ") and "stalled" in err[0], err
    assert not (tmp_path / "o").exists()


def test_the_timeout_from_the_environment_is_bounded(monkeypatch):
    for bad in ("0", "-1", "nan", "inf", "1e308", "soon"):
        monkeypatch.setenv("MECHKIN_READ_TIMEOUT", bad)
        assert guarded_read.read_timeout() == guarded_read.READ_TIMEOUT_S
    monkeypatch.setenv("MECHKIN_READ_TIMEOUT", "2.5")
    assert guarded_read.read_timeout() == 2.5


def test_ordinary_reads_are_unchanged(tmp_path):
    p = tmp_path / "a.yaml"
    p.write_bytes(b"x" * 3_000_000)
    assert guarded_read.read_bytes(p, what="file", limit=4_000_000) == b"x" * 3_000_000
    with pytest.raises(ConfigError, match="more than the limit"):
        guarded_read.read_bytes(p, what="file", limit=1_000_000)
