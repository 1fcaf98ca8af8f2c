"""Start-up of the compiled kernels: numba cache folder, the job-size rule, the first-use note
and ``mechkin warmup`` (issue 15: start-up)."""

from __future__ import annotations

import os
import sys

import pytest
from typer.testing import CliRunner

from mechkin.solvers.ik import accel


@pytest.fixture
def fresh_rule(monkeypatch):
    """The job-size rule as in a new process (nothing spent, nothing loaded), numba
    available, MECHKIN_JIT unset."""
    monkeypatch.delenv("MECHKIN_JIT", raising=False)
    monkeypatch.setattr(accel, "_loaded", set())
    monkeypatch.setattr(accel, "_spent", {"open": 0.0, "closed": 0.0})
    monkeypatch.setattr(accel, "_numba_installed", lambda: True)
    return accel


def test_user_cache_dir_follows_xdg(monkeypatch, tmp_path):
    if sys.platform in ("win32", "darwin"):
        pytest.skip("XDG_CACHE_HOME is the Linux/BSD convention")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert accel.user_cache_dir() == tmp_path / "mechkin" / "numba"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")  # the XDG spec: absolute only
    assert accel.user_cache_dir() == accel.Path.home() / ".cache" / "mechkin" / "numba"


def test_numba_cache_dir_set_by_the_user_is_kept(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    monkeypatch.setattr(accel, "_writable", lambda p: False)
    assert accel.configure_numba_cache() == str(tmp_path / "mine")
    assert os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "mine")


def test_unwritable_package_dir_uses_the_user_cache(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setattr(accel, "_writable", lambda p: False)
    cfg = sys.modules.get("numba.core.config")
    if cfg is not None:  # numba already imported: its config is updated too (restored here)
        monkeypatch.setattr(cfg, "CACHE_DIR", cfg.CACHE_DIR)
    got = accel.configure_numba_cache()
    want = tmp_path / "mechkin" / "numba"
    assert got == str(want)
    assert os.environ["NUMBA_CACHE_DIR"] == str(want)
    assert want.is_dir()
    if cfg is not None:
        assert str(want) == cfg.CACHE_DIR


def test_writable_package_dir_keeps_numbas_default(monkeypatch, tmp_path):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    assert accel._writable(tmp_path)  # a real check: it writes a temporary file there
    assert (tmp_path / "__pycache__").is_dir()
    assert accel.configure_numba_cache(tmp_path) is None
    assert "NUMBA_CACHE_DIR" not in os.environ


def test_small_jobs_run_numpy_until_they_would_repay_the_load(fresh_rule):
    a = fresh_rule
    # one big call: more numpy time than the load -> compiled at once
    big = int((a.OPEN_LOAD_S - a.OPEN_CALL_S) / a.OPEN_ROW_S) + 10
    assert a.use_compiled("open", big)
    # small calls: numpy while the estimated numpy time stays below the load cost
    n_small = 0
    while not a.use_compiled("open", 1):
        n_small += 1
        assert n_small < 1000
    assert n_small == int(a.OPEN_LOAD_S // (a.OPEN_CALL_S + a.OPEN_ROW_S))
    # closed chains: numpy costs far more per call, so the switch comes after a few calls
    n_closed = 0
    while not a.use_compiled("closed", 1):
        n_closed += 1
    assert n_closed == int(a.CLOSED_LOAD_S // (a.CLOSED_CALL_S + a.CLOSED_ROW_S))
    # once loaded, always compiled
    a.mark_loaded("open")
    assert a.use_compiled("open", 1)


def test_the_rule_obeys_mechkin_jit_and_a_patched_backend(fresh_rule, monkeypatch):
    a = fresh_rule
    monkeypatch.setenv("MECHKIN_JIT", "0")
    assert not a.use_compiled("open", 10**6)
    monkeypatch.setenv("MECHKIN_JIT", "1")
    assert a.use_compiled("open", 1)
    monkeypatch.delenv("MECHKIN_JIT")
    monkeypatch.setattr(a, "compiled_lm_available", lambda: True)  # tests choosing compiled
    assert a.use_compiled("open", 1) and a._spent["open"] == 0.0


def test_first_use_note_names_the_kernel_once(monkeypatch, capsys):
    monkeypatch.setattr(accel, "_announced", set())
    monkeypatch.setattr(accel, "is_cached", lambda d: False)
    accel.announce(object(), "serial_jit.lm")
    accel.announce(object(), "serial_jit.lm")
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1
    assert "serial_jit.lm" in err[0] and f"{accel.EXPECTED_COMPILE_S['serial_jit.lm']:.0f} s" \
        in err[0]
    monkeypatch.setattr(accel, "is_cached", lambda d: True)  # cached: nothing printed
    accel.announce(object(), "tree_jit.lm_closed")
    assert capsys.readouterr().err == ""


def test_is_cached_reads_numbas_index():
    pytest.importorskip("numba")
    from mechkin.solvers.ik import serial_jit

    assert accel.is_cached(serial_jit.half_wsq) in (True, False)


def test_warmup_compiles_a_tiny_mechanism(root):
    pytest.importorskip("numba")
    from mechkin.cli.app import app

    res = CliRunner().invoke(app, ["warmup", str(root / "mechanisms" / "planar3r.yaml")])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert lines[0].startswith("numba cache: ")
    assert os.environ["NUMBA_CACHE_DIR"] in lines[0]  # conftest's temporary folder
    for name in ("serial_jit.lm", "tree_jit.evaluate_one"):
        line = next(ln for ln in lines if name in ln)
        assert " s (" in line and ("compiled" in line or "loaded from cache" in line)
    # the kernels run: a compiled solve of the same mechanism now takes no compile
    from mechkin.solvers.ik import serial_jit

    assert serial_jit.lm.signatures
    assert accel.is_cached(serial_jit.lm) is True


def test_warmup_bad_mechanism_is_a_located_error(tmp_path):
    from mechkin.cli.app import app

    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nlinks: 3\n")
    res = CliRunner().invoke(app, ["warmup", str(bad)])
    assert res.exit_code == 2
    assert str(bad) in res.output
