"""Jobs run here, in worker processes or on a dask.distributed cluster."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import threading
import time
from collections.abc import Callable, Sequence

from ._validate import InputError

__all__ = ["worker_init", "stop_pool", "process_pool", "run_jobs", "check_scheduler",
           "connect_scheduler", "SCHEDULER_PROBE_SECONDS", "JOBS_PER_CORE"]

#: Local jobs allowed per core (``--jobs`` beyond ``JOBS_PER_CORE`` x cores is refused).
JOBS_PER_CORE = 4

#: Seconds the probe of a scheduler's TCP port waits for an answer
#: (:func:`check_scheduler`). A refusal comes back at once, whatever this is;
#: a port that stays silent this long is left to dask's own connect timeout.
SCHEDULER_PROBE_SECONDS = 2.0

#: Port of a scheduler address that names none (dask.distributed's default).
_DEFAULT_SCHEDULER_PORT = 8786


def worker_init(parent: int, threads: int | None = None) -> None:
    """In a pool worker: ignore SIGINT, die with the parent, use ``threads`` ray threads.

    The parent stops the pool itself on Ctrl-C (:func:`stop_pool`); a worker
    whose parent is killed dies too (Linux ``PR_SET_PDEATHSIG``, else a thread
    watching the parent's pid). ``threads`` None keeps the default ray threads.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if threads is not None:
        from .ray.embree_scene import set_workers

        set_workers(threads)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(1, signal.SIGKILL, 0, 0, 0) != 0:  # 1 = PR_SET_PDEATHSIG
            raise OSError(ctypes.get_errno(), "prctl")
    except (OSError, AttributeError):  # pragma: no cover - not Linux: watch the parent
        def watch() -> None:
            while os.getppid() == parent:
                time.sleep(0.5)
            os._exit(1)

        threading.Thread(target=watch, daemon=True).start()
    if os.getppid() != parent:  # the parent died before the prctl
        os._exit(1)


def stop_pool(pool) -> None:
    """Cancel every pending job of a ``ProcessPoolExecutor`` and kill its workers now."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:  # our own children, by their handles
        if p.is_alive():
            p.kill()
    for p in processes:
        p.join(timeout=2)


def process_pool(workers: int, threads: int | None = None):
    """A ``ProcessPoolExecutor`` of ``workers`` processes started by :func:`worker_init`."""
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(max_workers=max(1, workers), initializer=worker_init,
                               initargs=(os.getpid(), threads))


def check_scheduler(address: str) -> None:
    """Refuse at once a dask scheduler address that cannot be reached.

    For a ``tcp://`` or ``tls://`` address (a bare ``host:port`` is TCP), a
    plain socket connects to the host and port first, waiting at most
    :data:`SCHEDULER_PROBE_SECONDS`: a refused connection, an unknown host or
    an unreachable network is one line at once, where
    ``distributed.Client`` would retry until its connect timeout (30 s)
    runs out. A port that stays silent passes: the client's timeout is kept
    for that case. Other schemes (``inproc://``, ``ucx://``) are not probed.

    Raises
    ------
    InputError
        One line naming ``--scheduler``, the address and the problem.
    """
    from distributed.comm import parse_address, parse_host_port

    where = f"--scheduler {address!r}"
    try:
        scheme, location = parse_address(str(address))
        if scheme not in ("tcp", "tls"):
            return
        host, port = parse_host_port(location, _DEFAULT_SCHEDULER_PORT)
    except (ValueError, TypeError) as exc:
        raise InputError(f"{where}: not a scheduler address ({exc})") from None
    try:
        with socket.create_connection((host, port), timeout=SCHEDULER_PROBE_SECONDS):
            pass
    except TimeoutError:  # silence: dask's connect timeout decides
        return
    except ConnectionRefusedError:
        raise InputError(f"{where}: connection refused by {host}:{port} (no scheduler "
                         "listens there; start one with 'dask scheduler' or fix the port)"
                         ) from None
    except socket.gaierror as exc:
        raise InputError(f"{where}: unknown host {host!r} ({exc.strerror or exc})") from None
    except (OSError, OverflowError) as exc:  # unreachable network, a port beyond 65535
        raise InputError(f"{where}: cannot connect "
                         f"({getattr(exc, 'strerror', None) or exc})") from None


def connect_scheduler(address):
    """A dask.distributed client of ``--scheduler`` (a context manager), or a null context.

    ``address`` may be a string, a ``distributed.Client`` (used as it is, not
    closed) or None. Connected before any output folder is touched: an
    address that is malformed or whose port refuses the connection is refused
    at once (:func:`check_scheduler`), one that does not answer after dask's
    ``distributed.comm.timeouts.connect``; either with one line.
    """
    if address is None or not isinstance(address, str):  # none, or a client already
        return contextlib.nullcontext(address)
    try:
        from distributed import Client
    except ImportError:
        raise InputError("--scheduler: needs dask.distributed (pip install distributed)") from None
    check_scheduler(address)
    try:
        return Client(address)
    except (OSError, ValueError, TypeError) as exc:
        raise InputError(f"--scheduler {address!r}: cannot connect ({exc})") from None


def run_jobs(function: Callable, pending: Sequence[tuple], commit: Callable, *,
             jobs: int = 1, scheduler=None, threads: int | None = None) -> None:
    """Call ``function(*args)`` for each tuple of ``pending``; ``commit(result)`` here.

    Serially in this process when ``jobs`` <= 1 (or one job is pending), in a
    pool of ``jobs`` worker processes (each with ``threads`` ray threads), or
    on the dask cluster ``scheduler`` (an address or a ``Client``).
    ``commit`` is called in this process, in the order jobs finish. On any
    exception (Ctrl-C included) the jobs that finished are committed, the
    others cancelled and the workers killed, then the exception goes on.
    """
    if scheduler is not None:
        from distributed import as_completed as dask_completed

        with connect_scheduler(scheduler) as client:
            futures: dict = {}
            try:
                futures = {client.submit(function, *args, pure=False): args
                           for args in pending}
                for fut in dask_completed(list(futures)):
                    futures.pop(fut)
                    commit(fut.result())
            except BaseException:
                if futures:
                    client.cancel(list(futures))
                raise
        return
    if jobs <= 1 or len(pending) <= 1:
        for args in pending:
            commit(function(*args))
        return
    from concurrent.futures import FIRST_COMPLETED, wait

    pool = process_pool(min(jobs, len(pending)), threads)
    running: dict = {}
    try:
        running = {pool.submit(function, *args): args for args in pending}
        while running:
            done, _ = wait(list(running), return_when=FIRST_COMPLETED)
            for fut in done:
                del running[fut]
                commit(fut.result())
    except BaseException:
        try:
            for fut in list(running):
                if fut.done() and not fut.cancelled() and fut.exception() is None:
                    commit(fut.result())
        finally:
            stop_pool(pool)
        raise
    pool.shutdown(wait=True)
