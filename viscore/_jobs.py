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
           "connect_scheduler", "compile_ahead", "SCHEDULER_PROBE_SECONDS", "JOBS_PER_CORE"]

#: Local jobs allowed per core (``--jobs`` beyond ``JOBS_PER_CORE`` x cores is refused).
JOBS_PER_CORE = 4

#: Seconds the probe of a scheduler's TCP port waits for an answer
#: (:func:`check_scheduler`). A refusal comes back at once, whatever this is;
#: a port that stays silent this long is left to dask's own connect timeout.
SCHEDULER_PROBE_SECONDS = 2.0

#: Port of a scheduler address that names none (dask.distributed's default).
_DEFAULT_SCHEDULER_PORT = 8786
#: Highest TCP port.
_MAX_PORT = 65535
#: A dask TCP message opens with its length, an unsigned 64-bit little-endian integer
#: (``distributed.comm.tcp.TCP.read``, struct "Q").
_FRAME_LENGTH_BYTES = 8
#: Largest greeting accepted from a scheduler, bytes: its handshake is a msgpack map of
#: a few entries (compression, Python version, pickle protocol), well under 1 KB.
_MAX_GREETING_BYTES = 1 << 20


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


def _compile_steps(steps: Sequence[Callable[[], None]], parent: int) -> None:
    """In :func:`compile_ahead`'s helper: each step, then exit (its kernels are on disk)."""
    worker_init(parent)
    for step in steps:
        step()


def compile_ahead(here: Sequence[Callable[[], None]],
                  beside: Sequence[Callable[[], None]]) -> None:
    """Compile numba kernels in this process before it forks workers, on two cores.

    The steps ``beside`` run in a forked helper, whose kernels numba keeps in
    its disk cache (``cache=True``), while this process runs ``here``; then
    this process runs ``beside`` too, loading what the helper wrote. Each step
    compiles kernels (:func:`viscore._jit.compile_kernels`) and runs nothing
    else. Where numba keeps no cache (a read-only install), the helper's work
    is lost and this process compiles it again; where processes cannot fork,
    every step runs here.
    """
    import multiprocessing

    helper = None
    if beside and "fork" in multiprocessing.get_all_start_methods():
        helper = multiprocessing.get_context("fork").Process(
            target=_compile_steps, args=(list(beside), os.getpid()),
            name="viscore-compile", daemon=True)
        helper.start()
    try:
        for step in here:
            step()
    except BaseException:  # Ctrl-C included: the helper goes now
        if helper is not None:
            helper.kill()
            helper.join()
        raise
    if helper is not None:
        helper.join()
    for step in beside:
        step()


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

    For a ``tcp://``, ``tls://``, ``ws://`` or ``wss://`` address (a bare
    ``host:port`` is TCP), a plain socket connects to the host and port first,
    waiting at most :data:`SCHEDULER_PROBE_SECONDS`: a refused connection, an
    unknown host, an unreachable network or a port outside 1-65535 is one line
    at once, where ``distributed.Client`` would retry until its connect
    timeout (30 s) runs out. A port that does not answer the connection passes:
    the client's timeout is kept for that case. Over ``tcp://`` the scheduler's
    greeting is then read: a dask listener writes its handshake as soon as it
    accepts (``distributed.comm.core.Listener.on_connection``), a frame whose
    first 8 bytes are its length; a server that sends something else (an SSH
    banner: the client read it as a frame of exabytes, a MemoryError) or
    accepts and says nothing (the client waited for ever) is refused, the
    latter after dask's connect timeout. ``inproc://`` (a scheduler of this
    same process) and ``ucx://`` are not probed.

    Raises
    ------
    InputError
        One line naming ``--scheduler``, the address and the problem.
    """
    from distributed.comm import parse_address, parse_host_port

    where = f"--scheduler {address!r}"
    try:
        scheme, location = parse_address(str(address))
        if scheme not in ("tcp", "tls", "ws", "wss"):
            return
        host, port = parse_host_port(location, _DEFAULT_SCHEDULER_PORT)
    except (ValueError, TypeError) as exc:
        raise InputError(f"{where}: not a scheduler address ({exc})") from None
    if not 0 < int(port) <= _MAX_PORT:
        raise InputError(f"{where}: port {port} is not a TCP port (1 to {_MAX_PORT})")
    try:
        with socket.create_connection((host, port), timeout=SCHEDULER_PROBE_SECONDS) as sock:
            if scheme == "tcp":  # over TLS and websockets the greeting comes later
                _check_greeting(sock, where, f"{host}:{port}")
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


def _connect_timeout() -> float:
    """dask's ``distributed.comm.timeouts.connect``, seconds."""
    import dask
    from dask.utils import parse_timedelta

    return float(parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"),
                                 default="seconds"))


def _check_greeting(sock: socket.socket, where: str, peer: str) -> None:
    """Read the first 8 bytes a dask listener sends (:func:`check_scheduler`)."""
    wait = _connect_timeout()
    sock.settimeout(wait)
    head = b""
    try:
        while len(head) < _FRAME_LENGTH_BYTES:
            chunk = sock.recv(_FRAME_LENGTH_BYTES - len(head))
            if not chunk:
                break
            head += chunk
    except TimeoutError:
        raise InputError(f"{where}: {peer} accepted the connection but sent nothing in "
                         f"{wait:g} s, where a dask scheduler greets at once; is this a "
                         "scheduler's port?") from None
    except OSError as exc:
        raise InputError(f"{where}: {peer} cut the connection ({exc.strerror or exc})"
                         ) from None
    if len(head) < _FRAME_LENGTH_BYTES:
        raise InputError(f"{where}: {peer} closed the connection without a dask scheduler's "
                         f"greeting (sent {head!r})")
    length = int.from_bytes(head, "little")
    if not 0 < length <= _MAX_GREETING_BYTES:
        raise InputError(f"{where}: {peer} answered {head!r}, not a dask scheduler's greeting "
                         f"(read as a frame of {length:,} bytes); is this a scheduler's port?")


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
        why = ("no scheduler of this process has that inproc:// address; give a "
               "scheduler's tcp:// address" if str(address).startswith("inproc://")
               else f"cannot connect ({exc})")
        raise InputError(f"--scheduler {address!r}: {why}") from None


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
