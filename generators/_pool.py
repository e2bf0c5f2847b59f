"""Process pools of the generators: what a pool worker does first.

Shared by the level occluders (:mod:`viscore.generators.level_occluders`) and
the planar hierarchy's parallel node builds.
"""

from __future__ import annotations

import os
import signal
import threading
import time

__all__ = ["worker_init"]


def worker_init(parent: int, threads: int) -> None:
    """In a pool worker: ignore SIGINT, die with the parent, use ``threads`` ray threads."""
    from viscore import set_workers

    signal.signal(signal.SIGINT, signal.SIG_IGN)
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
    if os.getppid() != parent:
        os._exit(1)
