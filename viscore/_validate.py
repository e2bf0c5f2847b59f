"""Input checks shared by every public function of viscore, metrics and generators.

Validate once, at the public boundary: coerce, check shape, finiteness and
emptiness, and raise the single :class:`InputError` naming the argument, what
was expected and what was got. Private helpers trust their callers.
"""

from __future__ import annotations

import numbers

import numpy as np
import numpy.typing as npt

__all__ = ["InputError", "as_points", "as_vector", "as_unit_vectors", "as_positive",
           "as_positive_int", "as_fraction", "as_seed", "check_memory", "available_memory",
           "memory_limit"]


class InputError(ValueError):
    """Bad input: an argument, file or parameter that cannot be used.

    The message says which argument or file, what was expected and what was
    got. The command line maps it to exit code 2 with one line on stderr.
    """


def as_points(value: npt.ArrayLike, name: str, *, allow_empty: bool = False,
              finite: bool = True) -> np.ndarray:
    """Coerce to a finite ``(n, 3) float64`` array or raise :class:`InputError`.

    ``finite=False`` checks the shape only, for callers that check the values
    later on smaller pieces (``Scene`` checks each chunk of rays).
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except OverflowError as exc:  # an integer beyond float64's range
        raise InputError(f"{name}: a value is beyond float64's range") from exc
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected an (n, 3) array of numbers, got {value!r:.80}") from exc
    if arr.ndim == 1 and arr.shape[0] == 3:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(f"{name}: expected shape (n, 3), got {arr.shape}")
    if not allow_empty and len(arr) == 0:
        raise InputError(f"{name}: expected at least one point, got none")
    if finite and not np.isfinite(arr).all():
        raise InputError(f"{name}: contains NaN or infinite values")
    return arr


def as_vector(value: npt.ArrayLike, name: str) -> np.ndarray:
    """Coerce to a finite ``(3,) float64`` vector or raise :class:`InputError`."""
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except OverflowError as exc:  # an integer beyond float64's range
        raise InputError(f"{name}: a value is beyond float64's range") from exc
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected 3 numbers, got {value!r:.80}") from exc
    if arr.shape != (3,):
        raise InputError(f"{name}: expected 3 numbers, got {arr.size}")
    if not np.isfinite(arr).all():
        raise InputError(f"{name}: contains NaN or infinite values")
    return arr


def as_unit_vectors(value: npt.ArrayLike, name: str) -> np.ndarray:
    """Coerce to ``(n, 3)`` unit vectors; zero-length vectors raise :class:`InputError`."""
    arr = as_points(value, name, allow_empty=True)
    norm2 = np.einsum("ij,ij->i", arr, arr)
    if len(arr) == 0:
        return arr
    if norm2.min() <= 0:
        raise InputError(f"{name}: contains zero-length direction vectors")
    if np.abs(norm2 - 1.0).max() < 1e-12:  # already unit: no copy
        return arr
    return arr / np.sqrt(norm2)[:, None]


def as_positive(value: object, name: str) -> float:
    """A finite number > 0, or :class:`InputError`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name}: expected a positive number, got {value!r}")
    value = float(value)
    if not np.isfinite(value) or value <= 0:
        raise InputError(f"{name}: expected a positive finite number, got {value}")
    return value


def as_positive_int(value: object, name: str, *, maximum: int | None = None) -> int:
    """An integer >= 1 (and <= ``maximum`` when given), or :class:`InputError`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InputError(f"{name}: expected a positive integer, got {value!r}")
    value = int(value)
    if value < 1:
        raise InputError(f"{name}: expected a positive integer, got {value}")
    if maximum is not None and value > maximum:
        raise InputError(f"{name}: at most {maximum} allowed, got {value}")
    return value


def as_fraction(value: object, name: str, *, open_low: bool = False) -> float:
    """A number in [0, 1] (or (0, 1] with ``open_low``), or :class:`InputError`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name}: expected a number in [0, 1], got {value!r}")
    value = float(value)
    low_ok = value > 0 if open_low else value >= 0
    if not (np.isfinite(value) and low_ok and value <= 1):
        bracket = "(" if open_low else "["
        raise InputError(f"{name}: expected a number in {bracket}0, 1], got {value}")
    return value


#: Share of the available memory that one computation may plan to use before
#: it is refused (``VISCORE_MEMORY_FRACTION`` overrides it).
MEMORY_FRACTION = 0.75


def as_seed(value: object, name: str = "seed") -> int:
    """A non-negative integer of any size (what ``numpy.random.default_rng`` takes).

    The one seed rule of the toolkit: ``None`` is refused too, since every
    Monte-Carlo result must be reproducible from the seed it records.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InputError(f"{name}: expected a non-negative integer, got {value!r}")
    value = int(value)
    if value < 0:
        raise InputError(f"{name}: expected a non-negative integer, got {value}")
    return value


def available_memory() -> int:
    """Bytes of memory available to this process now (Linux ``MemAvailable``).

    Falls back to the physical memory size where ``/proc/meminfo`` is absent.
    """
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    import os

    return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def _memory_fraction() -> float:
    import os

    return float(os.environ.get("VISCORE_MEMORY_FRACTION", MEMORY_FRACTION))


def memory_limit() -> float:
    """Bytes one computation may plan to use: the share :func:`check_memory` allows."""
    return _memory_fraction() * available_memory()


def check_memory(nbytes: float, what: str) -> None:
    """Refuse, before any work, a computation whose estimated memory does not fit.

    Parameters
    ----------
    nbytes : float
        Estimated peak bytes of the computation (an upper estimate; may
        overflow int64, so pass a float).
    what : str
        The argument(s) that size it, e.g. ``"voxels=629"``; named in the error.

    Raises
    ------
    InputError
        If ``nbytes`` exceeds ``MEMORY_FRACTION`` (default 0.75; environment
        variable ``VISCORE_MEMORY_FRACTION``) of :func:`available_memory`. The
        message gives the estimate and the limit.
    """

    fraction = _memory_fraction()
    limit = fraction * available_memory()
    try:  # a Python int beyond int64 (e.g. a count of 2**64 x bytes) is fine here too
        nbytes = float(nbytes)
    except OverflowError:
        nbytes = float("inf")
    if not np.isfinite(nbytes) or nbytes > limit:
        raise InputError(f"{what}: needs about {_human_bytes(nbytes)} of memory, more than the "
                         f"limit of {_human_bytes(limit)} ({_percent(fraction)} of available "
                         "memory)")


def _percent(fraction: float) -> str:
    """A share as a percentage with three significant digits: 75%, 0.1%, 0.0001%.

    ``format(0.001, ".0%")`` reads "0%": a small ``VISCORE_MEMORY_FRACTION``
    must still read as the share it is.

    Examples
    --------
    >>> _percent(0.75), _percent(0.001), _percent(1.5e-6)
    ('75%', '0.1%', '0.00015%')
    """
    return f"{100 * fraction:.3g}%"


def _human_bytes(n: float) -> str:
    if not np.isfinite(n):
        return "an unbounded amount"
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.1f} PiB"
