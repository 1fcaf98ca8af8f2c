"""Independent jobs run in order: sequentially, on local processes or on a Dask cluster.

:func:`run_jobs` runs a list of independent jobs (a picklable top-level function and one
argument per job) in order, sequentially (``workers=1``), on local processes
(:class:`concurrent.futures.ProcessPoolExecutor`) or on a Dask cluster (``address`` of a
scheduler; needs the optional extra ``mechkin[dask]``). Results come back in job order and a
job never depends on how many workers there are, so every executor gives identical results.
A ``progress(done, total)`` callback reports completed jobs. :func:`connect_cluster` checks a
scheduler before any work, every probe bounded by ``MECHKIN_DASK_TIMEOUT`` (in (0, 600] s): a
refused port answers at once, a stopped worker's silence times out. Local workers leave as soon
as mechkin's process is gone (:func:`die_with_parent`). Split out of ``sweeps.py`` (issue 23:
modules that fit in a head); the names stay importable from
:mod:`mechkin.solvers.workspace.sweeps`.

Imports: the standard library (dask lazily), mechkin.errors.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from typing import Any, TypeVar

T = TypeVar("T")
R = TypeVar("R")

ProgressCallback = Callable[[int, int], None]
"""``progress(done, total)``: called once with ``done = 0`` and after every completed job."""


# --------------------------------------------------------------------------- execution


def default_workers(n_jobs: int) -> int:
    """min(cpu count, number of jobs), at least 1."""
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(cpus or 1, n_jobs))


def _mp_context() -> multiprocessing.context.BaseContext:
    """forkserver on POSIX (no fork of a threaded parent, e.g. a progress-bar thread), else
    spawn; the server preloads this module so workers start without re-importing numpy."""
    if sys.platform != "win32" and "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["mechkin.solvers.workspace.sweeps"])
        return ctx
    return multiprocessing.get_context("spawn")


def die_with_parent(main_pid: int) -> None:
    """A worker's initializer: the worker leaves as soon as mechkin's process ``main_pid`` is
    gone, however it ended (SIGKILL included). A forkserver's workers hold the server's
    liveness pipe, so neither the server nor they would otherwise notice; a daemon thread
    polls ``main_pid`` once a second (and on Linux the kernel also kills the worker with its
    parent, PR_SET_PDEATHSIG)."""
    import signal
    import threading
    import time

    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):  # pragma: no cover - no prctl
            pass

    def gone() -> bool:
        try:
            os.kill(main_pid, 0)
        except ProcessLookupError:
            return True
        except OSError:
            return False
        return False

    def watch() -> None:
        while not gone():
            time.sleep(1.0)
        os._exit(1)

    if gone():
        os._exit(1)
    threading.Thread(target=watch, daemon=True, name="mechkin-parent-watch").start()


def run_jobs(
    fn: Callable[[T], R],
    jobs: Sequence[T],
    *,
    workers: int | None = None,
    address: str | None = None,
    progress: ProgressCallback | None = None,
    stop: Callable[[], bool] | None = None,
) -> list[R]:
    """Run ``fn(job)`` for every job and return the results in job order.

    Parameters
    ----------
    fn : callable
        A module-level (picklable) function.
    jobs : sequence
        One picklable argument per job.
    workers : int, optional
        Local processes (default :func:`default_workers`); 1 runs in this process. Ignored
        when ``address`` is given.
    address : str, optional
        Address of a Dask scheduler (``tcp://host:port``): the jobs run on that cluster
        (``pip install mechkin[dask]``).
    progress : callable, optional
        ``progress(done, total)``.
    stop : callable, optional
        ``stop()`` after every finished job: when True, no further job starts (local
        processes: the pending ones are cancelled) and the results of the first jobs that
        finished in a row are returned (a prefix of the list; the caller keeps those rows).

    Returns
    -------
    list
        ``[fn(job) for job in jobs]``, whatever the executor (a prefix of it after a stop).

    Raises
    ------
    ImportError
        ``address`` given but dask.distributed is not installed.
    """
    total = len(jobs)
    if progress is not None:
        progress(0, total)
    if total == 0:
        return []
    if address is not None:
        return _run_dask(fn, jobs, address, progress, stop)
    n = default_workers(total) if workers is None else max(1, min(int(workers), total))
    if n == 1:
        out: list[R] = []
        for i, job in enumerate(jobs):
            out.append(fn(job))
            if progress is not None:
                progress(i + 1, total)
            if stop is not None and i + 1 < total and stop():
                break
        return out
    results: list[Any] = [_NOT_RUN] * total
    with ProcessPoolExecutor(max_workers=n, mp_context=_mp_context(),
                             initializer=die_with_parent, initargs=(os.getpid(),)) as pool:
        futures: dict[Future[R], int] = {pool.submit(fn, job): i for i, job in enumerate(jobs)}
        if _collect(as_completed(futures), futures, results, total, progress, stop):
            pool.shutdown(wait=True, cancel_futures=True)
            for fut, i in futures.items():  # finished while the others were cancelled
                if results[i] is _NOT_RUN and fut.done() and not fut.cancelled():
                    results[i] = fut.result()
            k = next((i for i, r in enumerate(results) if r is _NOT_RUN), total)
            return results[:k]
    return results


_NOT_RUN: Any = object()


def _collect(done_iter: Iterable[Any], index: Mapping[Any, int], results: list[Any], total: int,
             progress: ProgressCallback | None, stop: Callable[[], bool] | None = None
             ) -> bool:
    """Gather the results as they finish; True when ``stop()`` asked to stop early."""
    for k, fut in enumerate(done_iter, start=1):
        results[index[fut]] = fut.result()
        if progress is not None:
            progress(k, total)
        if stop is not None and k < total and stop():
            return True
    return False


#: Seconds to reach a scheduler and to see a worker (``MECHKIN_DASK_TIMEOUT`` overrides).
DASK_TIMEOUT_S = 10.0
_PROBE = "__import__('mechkin').__version__"


#: The longest wait ``MECHKIN_DASK_TIMEOUT`` may ask for.
MAX_DASK_TIMEOUT_S = 600.0


def _dask_timeout() -> float:
    """``MECHKIN_DASK_TIMEOUT`` seconds, in (0, 600] (ClusterError otherwise: 1e308 or inf
    would wait for ever), default :data:`DASK_TIMEOUT_S`."""
    import math
    import os

    from mechkin.errors import ClusterError

    raw = os.environ.get("MECHKIN_DASK_TIMEOUT", "")
    if not raw.strip():
        return DASK_TIMEOUT_S
    try:
        t = float(raw)
    except ValueError:
        t = math.nan
    if not 0 < t <= MAX_DASK_TIMEOUT_S:
        raise ClusterError(f"MECHKIN_DASK_TIMEOUT: expected seconds in (0, "
                           f"{MAX_DASK_TIMEOUT_S:g}], got {raw[:40]!r}")
    return t


def _port_open(address: str, timeout: float) -> OSError | None:
    """Connect to ``tcp://host:port`` once (a refused port answers at once, where the Dask
    comm retries until its timeout); the error, or None if something listens."""
    import socket
    from urllib.parse import urlsplit

    try:
        u = urlsplit(address)
        host, port = u.hostname, u.port
    except ValueError as exc:
        return OSError(str(exc))
    if not host or port is None:
        return None  # let the comm report it
    try:
        with socket.create_connection((host, port), timeout=min(timeout, 5.0)):
            return None
    except OSError as exc:
        return exc


def _run_with_timeout(fn: Callable[[], R], timeout: float) -> tuple[bool, R | None]:
    """(True, fn()) if ``fn`` returns within ``timeout`` s, else (False, None); ``fn`` runs in
    a daemon thread (a stopped worker never answers a broadcast)."""
    import threading

    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = fn()
        except BaseException as exc:  # noqa: BLE001 - re-raised in the caller
            box["error"] = exc

    th = threading.Thread(target=target, daemon=True, name="mechkin-dask-probe")
    th.start()
    th.join(timeout)
    if th.is_alive():
        return False, None
    if "error" in box:
        raise box["error"]
    return True, box.get("value")


def _probe_scheduler(address: str, shown: str, timeout: float) -> None:
    """Ask ``address`` who it is (the comm handshake and the ``identity`` op, both under one
    timeout): a port that accepts but never answers (not a Dask scheduler) must not hang."""
    import asyncio

    from distributed.core import rpc

    from mechkin.errors import ClusterError

    if address.startswith("tcp://"):
        err = _port_open(address, timeout)
        if err is not None:
            raise ClusterError(f"--scheduler {shown}: no Dask scheduler answered "
                               f"({type(err).__name__}: {err.strerror or err}); is it running "
                               "at that address?")

    async def ask() -> Any:
        r = rpc(address, timeout=timeout)
        try:
            return await asyncio.wait_for(r.identity(), timeout)
        finally:
            await r.close_rpc()

    try:
        info = asyncio.run(asyncio.wait_for(ask(), timeout + 1.0))
    except (OSError, TimeoutError, asyncio.TimeoutError, ValueError, EOFError) as exc:
        raise ClusterError(f"--scheduler {shown}: no Dask scheduler answered within "
                           f"{timeout:g} s ({type(exc).__name__}); is it running at that "
                           "address?") from None
    except Exception as exc:  # noqa: BLE001 - any protocol failure means: not a scheduler
        raise ClusterError(f"--scheduler {shown}: not a Dask scheduler ({type(exc).__name__})"
                           ) from None
    if not isinstance(info, dict) or info.get("type") != "Scheduler":
        raise ClusterError(f"--scheduler {shown}: answered, but is not a Dask scheduler")


def connect_cluster(address: str) -> Any:
    """A ``distributed.Client`` on ``address`` whose workers run this mechkin version.

    Fails fast, each with one line (ClusterError, exit 2): an address that is not
    ``tcp://host:port`` (or ``tls://``), nothing listening or no Dask scheduler answering
    within the timeout, no worker within the timeout, workers that cannot import mechkin or run
    another version of it.
    """
    from mechkin import __version__
    from mechkin.errors import ClusterError

    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - depends on the optional extra
        raise ClusterError("--scheduler: running on a Dask cluster needs the optional extra: "
                           "pip install 'mechkin[dask]'") from exc
    shown = address if len(address) <= 80 else address[:77] + "..."
    if "://" not in address or address.split("://", 1)[0] not in ("tcp", "tls", "inproc"):
        raise ClusterError(f"--scheduler {shown}: expected an address like tcp://HOST:8786")
    timeout = _dask_timeout()
    _probe_scheduler(address, shown, timeout)
    try:
        client = Client(address, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"--scheduler {shown}: no Dask scheduler answered within "
                           f"{timeout:g} s ({type(exc).__name__}); is it running at that "
                           "address?") from None
    try:
        try:
            client.wait_for_workers(1, timeout=timeout)
        except (TimeoutError, OSError):
            raise ClusterError(f"--scheduler {shown}: the scheduler has no workers (none "
                               f"joined within {timeout:g} s)") from None
        answered, versions = _run_with_timeout(
            lambda: client.run(eval, _PROBE, on_error="return"), timeout)
        if not answered or not isinstance(versions, dict):
            raise ClusterError(f"--scheduler {shown}: the workers did not answer within "
                               f"{timeout:g} s (a stopped or overloaded worker?)")
        bad = {w: v for w, v in versions.items() if v != __version__}
        if bad:
            w, v = next(iter(bad.items()))
            why = (f"cannot import mechkin ({type(v).__name__}: {str(v)[:60]})"
                   if isinstance(v, BaseException) else f"runs mechkin {str(v)[:20]}")
            raise ClusterError(f"--scheduler {shown}: {len(bad)} of {len(versions)} workers "
                               f"cannot run this job: worker {w} {why}, this is mechkin "
                               f"{__version__}; install the same mechkin on every worker")
    except BaseException:
        client.close()
        raise
    return client


def _run_dask(fn: Callable[[T], R], jobs: Sequence[T], address: str,
              progress: ProgressCallback | None,
              stop: Callable[[], bool] | None = None) -> list[R]:
    """The jobs on a Dask cluster, watched: when no job finishes for ``MECHKIN_DASK_TIMEOUT``
    seconds, the workers holding the pending jobs must answer a ping within that time, else
    the run stops (:class:`~mechkin.errors.ClusterLostError`, one line, exit 1): a worker
    stopped with SIGSTOP, hung or cut off still counts as alive for the scheduler for minutes,
    and its jobs would be waited for for ever."""
    import asyncio

    from distributed import wait as dask_wait

    from mechkin.errors import ClusterError

    results: list[Any] = [_NOT_RUN] * len(jobs)
    shown = address if len(address) <= 80 else address[:77] + "..."
    timeout = _dask_timeout()
    client = connect_cluster(address)
    try:
        futures = [client.submit(fn, job, pure=False) for job in jobs]
        index = {f.key: i for i, f in enumerate(futures)}
        pending = set(futures)
        k = 0
        while pending:
            try:
                done, pending = dask_wait(pending, timeout=timeout,
                                          return_when="FIRST_COMPLETED")
            except (TimeoutError, asyncio.TimeoutError, OSError):
                _check_alive(client, shown, timeout, len(pending))
                continue
            for fut in done:
                try:
                    results[index[fut.key]] = fut.result()
                except (ImportError, ModuleNotFoundError, AttributeError) as exc:
                    raise ClusterError(f"--scheduler {shown}: a worker could not run the job "
                                       f"({type(exc).__name__}: {str(exc)[:80]})") from None
                k += 1
                if progress is not None:
                    progress(k, len(jobs))
            if pending and stop is not None and stop():
                break
    finally:
        _close_quietly(client, timeout)
    first = next((i for i, r in enumerate(results) if r is _NOT_RUN), len(jobs))
    return results[:first]


def _check_alive(client: Any, shown: str, timeout: float, n_pending: int) -> None:
    """No job finished within ``timeout``: the workers running the pending jobs must answer a
    ping within ``timeout`` (a busy worker does: its event loop is not the job's thread)."""
    from mechkin.errors import ClusterLostError

    answered, busy = _run_with_timeout(lambda: client.processing(), timeout)
    if not answered:
        raise ClusterLostError(f"--scheduler {shown}: the scheduler stopped answering "
                               f"(nothing within {timeout:g} s, MECHKIN_DASK_TIMEOUT) with "
                               f"{n_pending} jobs pending; nothing written")
    workers = [w for w, keys in (busy or {}).items() if keys] or None
    answered, pongs = _run_with_timeout(
        lambda: client.run(int, workers=workers, on_error="return"), timeout)
    if not answered or not isinstance(pongs, dict):
        who = (f"worker {workers[0]}" if workers and len(workers) == 1
               else "a worker running its jobs")
        raise ClusterLostError(f"--scheduler {shown}: {who} stopped answering (no reply "
                               f"within {timeout:g} s, MECHKIN_DASK_TIMEOUT: stopped, hung or "
                               f"cut off?) with {n_pending} jobs pending; nothing written")


def _close_quietly(client: Any, timeout: float) -> None:
    """Close the client without waiting on a lost worker: pending jobs cancelled, at most
    ``timeout`` s."""
    import contextlib

    with contextlib.suppress(Exception):
        _run_with_timeout(lambda: client.close(timeout=timeout), timeout + 1.0)
