"""Distributed runs that fail fast: a wrong address, a scheduler without workers and workers
that cannot import mechkin each end in one clear line well within 30 s. Every server binds to
127.0.0.1 with the dashboard off and is stopped by the test."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from mechkin.errors import ClusterError
from mechkin.solvers.workspace.sweeps import connect_cluster

distributed = pytest.importorskip("distributed")
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _short_timeout(monkeypatch):
    monkeypatch.setenv("MECHKIN_DASK_TIMEOUT", "3")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _timed(fn):
    t0 = time.perf_counter()
    with pytest.raises(ClusterError) as exc:
        fn()
    assert time.perf_counter() - t0 < 30
    assert len(str(exc.value).splitlines()) == 1
    return str(exc.value)


def test_not_an_address():
    msg = _timed(lambda: connect_cluster("localhost:8786"))
    assert "expected an address like tcp://HOST:8786" in msg


def test_nothing_listening():
    port = _free_port()
    msg = _timed(lambda: connect_cluster(f"tcp://127.0.0.1:{port}"))
    assert "no Dask scheduler answered" in msg


def test_a_port_that_is_not_a_scheduler():
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    port = srv.getsockname()[1]
    conns = []
    stop = threading.Event()

    def accept():
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                conns.append(srv.accept()[0])  # accept and never answer
            except OSError:
                continue

    t = threading.Thread(target=accept, daemon=True)
    t.start()
    try:
        msg = _timed(lambda: connect_cluster(f"tcp://127.0.0.1:{port}"))
        assert "no Dask scheduler answered" in msg
    finally:
        stop.set()
        t.join(timeout=5)
        for c in conns:
            c.close()
        srv.close()


def _cluster(n_workers: int):
    return distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1,
                                    processes=False, protocol="tcp", host="127.0.0.1",
                                    dashboard_address="127.0.0.1:0")


def test_a_scheduler_without_workers():
    with _cluster(0) as cluster:
        msg = _timed(lambda: connect_cluster(cluster.scheduler_address))
        assert "has no workers" in msg


BLOCKER = """
import sys
class _NoMechkin:
    def find_spec(self, name, path=None, target=None):
        if name == "mechkin" or name.startswith("mechkin."):
            raise ModuleNotFoundError("No module named 'mechkin'", name=name)
        return None
sys.meta_path.insert(0, _NoMechkin())
from distributed.cli.dask_worker import main
sys.argv = ["dask-worker", sys.argv[1], "--nthreads", "1", "--no-dashboard", "--host",
            "127.0.0.1", "--no-nanny"]
main()
"""


def test_workers_without_mechkin():
    with _cluster(0) as cluster:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        worker = subprocess.Popen([sys.executable, "-c", BLOCKER, cluster.scheduler_address],
                                  env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with distributed.Client(cluster.scheduler_address, set_as_default=False) as c:
                c.wait_for_workers(1, timeout=60)
            msg = _timed(lambda: connect_cluster(cluster.scheduler_address))
            assert "cannot import mechkin" in msg and "install the same mechkin" in msg
        finally:
            worker.terminate()
            try:
                worker.wait(timeout=20)
            except subprocess.TimeoutExpired:
                worker.kill()


def test_a_working_cluster_passes():
    with _cluster(1) as cluster:
        client = connect_cluster(cluster.scheduler_address)
        try:
            assert client.submit(sum, [1, 2]).result() == 3
        finally:
            client.close()


def test_cli_wrong_scheduler_is_one_line(tmp_path):
    port = _free_port()
    env = dict(os.environ, PYTHONPATH=str(ROOT), MECHKIN_DASK_TIMEOUT="3", MPLBACKEND="Agg")
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "mechkin", "workspace",
                        str(ROOT / "scenarios" / "lee_design_sweep_r.yaml"), "--out",
                        str(tmp_path / "o"), "--scheduler", f"tcp://127.0.0.1:{port}"],
                       capture_output=True, text=True, timeout=120, env=env)
    assert time.perf_counter() - t0 < 60
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "no Dask scheduler" in r.stderr
    assert not (tmp_path / "o").exists()


WORKER = """
import sys
from distributed.cli.dask_worker import main
sys.argv = ["dask-worker", sys.argv[1], "--nthreads", "1", "--no-dashboard", "--host",
            "127.0.0.1", "--no-nanny"]
main()
"""


def test_a_stopped_worker_fails_fast():
    """A worker stopped with SIGSTOP still counts for the scheduler; the version probe must
    not wait for it for ever (issue 28 item 7: --scheduler hung with no output)."""
    import signal

    with _cluster(0) as cluster:
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        worker = subprocess.Popen([sys.executable, "-c", WORKER, cluster.scheduler_address],
                                  env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with distributed.Client(cluster.scheduler_address, set_as_default=False) as c:
                c.wait_for_workers(1, timeout=60)
            os.kill(worker.pid, signal.SIGSTOP)
            msg = _timed(lambda: connect_cluster(cluster.scheduler_address))
            assert "did not answer within 3 s" in msg
        finally:
            os.kill(worker.pid, signal.SIGCONT)
            worker.terminate()
            try:
                worker.wait(timeout=20)
            except subprocess.TimeoutExpired:
                worker.kill()
                worker.wait()


def _stop_worker(worker: subprocess.Popen) -> None:
    import signal

    os.kill(worker.pid, signal.SIGCONT)
    worker.terminate()
    try:
        worker.wait(timeout=20)
    except subprocess.TimeoutExpired:
        worker.kill()
        worker.wait()


def test_a_worker_stopped_mid_job_fails_fast():
    """A worker SIGSTOPped while it runs the jobs: no job finishes within MECHKIN_DASK_TIMEOUT
    (3 s here), the worker does not answer a ping within it either, so the run stops with one
    line (ClusterLostError, exit 1) instead of waiting for ever (issue 28)."""
    import signal

    from mechkin.errors import ClusterLostError
    from mechkin.solvers.workspace.jobs import run_jobs

    with _cluster(0) as cluster:
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        worker = subprocess.Popen([sys.executable, "-c", WORKER, cluster.scheduler_address],
                                  env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with distributed.Client(cluster.scheduler_address, set_as_default=False) as c:
                c.wait_for_workers(1, timeout=60)
            seen = []

            def progress(done: int, total: int) -> None:
                seen.append(done)
                if done == 1:  # the first job is back: stop the worker in the middle
                    os.kill(worker.pid, signal.SIGSTOP)

            t0 = time.perf_counter()
            with pytest.raises(ClusterLostError) as exc:
                run_jobs(time.sleep, [0.2] * 40, address=cluster.scheduler_address,
                         progress=progress)
            assert time.perf_counter() - t0 < 60
            msg = str(exc.value)
            assert len(msg.splitlines()) == 1 and len(msg) <= 300, msg
            assert "stopped answering" in msg and "MECHKIN_DASK_TIMEOUT" in msg
            assert ClusterLostError.exit_code == 1 and 1 in seen and 40 not in seen
        finally:
            _stop_worker(worker)


def test_the_cli_stops_with_one_line_and_the_folder_unchanged(tmp_path):
    """The same through ``mechkin workspace --scheduler``: the worker is stopped once it runs
    a job; exit 1, one line, no output folder (nothing written)."""
    import signal

    import yaml

    d = yaml.safe_load((ROOT / "scenarios" / "puma560_reachability.yaml").read_text())
    d["mechanism"] = str(ROOT / "mechanisms" / "puma560.yaml")
    d["workspace"]["chunk"] = 4
    d["outputs"] = {"csv": True, "plots": False, "mcap": False}
    sc = tmp_path / "reach.yaml"
    sc.write_text(yaml.safe_dump(d))
    out = tmp_path / "o"
    with _cluster(0) as cluster:
        env = dict(os.environ, PYTHONPATH=str(ROOT), MECHKIN_DASK_TIMEOUT="3")
        worker = subprocess.Popen([sys.executable, "-c", WORKER, cluster.scheduler_address],
                                  env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        run = None
        try:
            with distributed.Client(cluster.scheduler_address, set_as_default=False) as c:
                c.wait_for_workers(1, timeout=60)
                run = subprocess.Popen([sys.executable, "-m", "mechkin", "workspace", str(sc),
                                        "--out", str(out), "--scheduler",
                                        cluster.scheduler_address], env=env, text=True,
                                       stdout=subprocess.PIPE, stderr=subprocess.PIPE)
                t0 = time.perf_counter()
                while not any(c.processing().values()) and time.perf_counter() - t0 < 120:
                    time.sleep(0.05)  # until the worker holds a job
                os.kill(worker.pid, signal.SIGSTOP)
            _, err = run.communicate(timeout=120)
            lines = [ln for ln in err.splitlines() if ln.strip()]
            assert run.returncode == 1, err
            assert len(lines) == 1 and "stopped answering" in lines[0], lines
            assert not out.exists() and not list(tmp_path.glob(".*"))
        finally:
            if run is not None and run.poll() is None:
                run.kill()
                run.wait()
            _stop_worker(worker)


def test_a_busy_worker_is_not_taken_for_a_lost_one(monkeypatch):
    """Jobs longer than the timeout on a live worker: it answers the ping, the run goes on."""
    from mechkin.solvers.workspace.jobs import run_jobs

    with _cluster(0) as cluster:
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        worker = subprocess.Popen([sys.executable, "-c", WORKER, cluster.scheduler_address],
                                  env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            with distributed.Client(cluster.scheduler_address, set_as_default=False) as c:
                c.wait_for_workers(1, timeout=60)
            monkeypatch.setenv("MECHKIN_DASK_TIMEOUT", "1")
            assert run_jobs(time.sleep, [2.5, 0.1], address=cluster.scheduler_address) == [
                None, None]
        finally:
            _stop_worker(worker)


@pytest.mark.parametrize("value", ["1e308", "inf", "nan", "-1", "0", "soon"])
def test_the_timeout_from_the_environment_is_bounded(monkeypatch, value):
    monkeypatch.setenv("MECHKIN_DASK_TIMEOUT", value)
    msg = _timed(lambda: connect_cluster(f"tcp://127.0.0.1:{_free_port()}"))
    assert msg.startswith("MECHKIN_DASK_TIMEOUT: expected seconds in (0, 600]")


def test_a_closed_port_is_refused_at_once(monkeypatch):
    monkeypatch.setenv("MECHKIN_DASK_TIMEOUT", "10")
    t0 = time.perf_counter()
    msg = _timed(lambda: connect_cluster(f"tcp://127.0.0.1:{_free_port()}"))
    assert time.perf_counter() - t0 < 5  # was 10.5 s: the comm retried until its timeout
    assert "ConnectionRefusedError" in msg
