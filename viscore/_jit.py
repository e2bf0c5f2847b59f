"""numba compilation that works from a read-only install."""

from __future__ import annotations

import logging
from collections.abc import Callable

__all__ = ["njit_cached"]

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
