"""numba compilation that works from a read-only install."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

__all__ = ["njit_cached", "pinned_kernels", "compile_kernels"]

_log = logging.getLogger(__name__)


def njit_cached(**options) -> Callable:
    """``numba.njit(cache=True, **options)``, without the cache where numba cannot keep one.

    Parameters
    ----------
    **options
        Passed to :func:`numba.njit` (``inline``, ``parallel``...).

    Returns
    -------
    decorator
        Compiles the decorated function lazily, as ``numba.njit`` does.
    """
    import numba

    def decorate(func: Callable) -> Callable:
        try:
            return numba.njit(cache=True, **options)(func)
        except RuntimeError as exc:  # "cannot cache function ...: no locator available"
            if "cannot cache" not in str(exc):
                raise
            _log.debug("numba: no writable cache folder for %s; compiling without a cache",
                       func.__qualname__)
            return numba.njit(cache=False, **options)(func)

    return decorate


def _argument_types(signature) -> tuple:
    """A kernel signature as the tuple of its argument types, the form numba compiles a
    call's version for.

    numba keys its disk cache by the signature exactly as ``compile`` is given it: a
    version compiled from the string ``"(float64[::1],)"`` is filed apart from the same
    version compiled for a call, and each finds only its own. A kernel compiled ahead
    from a string was compiled again by the first process that called it (a ``cull``
    after a ``compare``, the tests), and the reverse.
    """
    from numba.core import sigutils

    args, _ = sigutils.normalize_signature(signature)
    return tuple(args)


def pinned_kernels(signatures: Callable[[], dict]) -> Callable[[], None]:
    """A function that compiles (or loads from numba's cache) kernels once, each for the
    signatures ``signatures()`` maps it to, and then forbids it other versions.

    Left to compile for the argument types of each call, numba builds a new
    version for every layout and writeability the arrays come in; pinned, a
    kernel has the versions named here, to which callers convert their arrays.
    Thread-safe; kernels run as Python under ``NUMBA_DISABLE_JIT`` are left as
    they are.
    """
    lock = threading.Lock()
    ready = False

    def ready_kernels() -> None:
        nonlocal ready
        if ready:
            return
        with lock:
            if not ready:
                for kernel, kernel_signatures in signatures().items():
                    if hasattr(kernel, "disable_compile"):  # not under NUMBA_DISABLE_JIT
                        for signature in kernel_signatures:
                            kernel.compile(_argument_types(signature))
                        kernel.disable_compile()
                ready = True

    return ready_kernels


def compile_kernels(signatures: dict) -> None:
    """Compile (or load from numba's cache) each kernel for the signatures it is mapped to.

    Unlike :func:`pinned_kernels`, other versions stay allowed: a call with
    other argument types compiles one as before. Compiled in a process that
    then forks, the kernels are the children's without compiling; compiled in
    a process of their own, they are on disk (``cache=True``) for the next
    process to load. Kernels run as Python under ``NUMBA_DISABLE_JIT`` are
    left as they are.

    Parameters
    ----------
    signatures : dict
        Kernel (a ``numba`` dispatcher) -> list of signatures (numba types or
        their strings).
    """
    for kernel, kernel_signatures in signatures.items():
        if hasattr(kernel, "compile"):  # not under NUMBA_DISABLE_JIT
            for signature in kernel_signatures:
                kernel.compile(_argument_types(signature))
