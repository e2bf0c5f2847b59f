"""Log records held back while a generator runs another many times, then said once."""

from __future__ import annotations

import contextlib
import logging
import re
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import TypeVar

__all__ = ["held_records", "release", "report_parts", "call_held", "portable", "restored",
           "report_kinds", "UNHELD"]

T = TypeVar("T")

#: Stands for a part's own name while texts are grouped (:func:`report_parts`).
_EACH = "\x00each\x00"

#: Stands for a number while texts are grouped: texts that differ only by their numbers
#: (one mesh's walls of 0.006 need voxels of 0.003, another's of 0.01) are one kind.
_NUMBER = "\x00n\x00"

#: A number of a text, not part of a name (``Plane.086``, ``GLTF_19``).
_NUMBER_RE = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?(?!\w)")


def _template(text: str) -> tuple[str, list[str]]:
    """``text`` with each number replaced by :data:`_NUMBER`, and the numbers."""
    return _NUMBER_RE.sub(_NUMBER, text), _NUMBER_RE.findall(text)


def _filled(key: str, numbers: Sequence[Sequence[str]]) -> str:
    """A grouped text again: each number the one all texts had, or their range."""
    pieces = key.split(_NUMBER)
    out = [pieces[0]]
    for k, piece in enumerate(pieces[1:]):
        column = [row[k] for row in numbers]
        lo, hi = min(column, key=float), max(column, key=float)
        out.append(lo if float(lo) == float(hi) else f"{lo} to {hi}")
        out.append(piece)
    return "".join(out)

#: The loggers held: this one and every logger below it.
_PREFIX = "viscore"

#: A record with this attribute true is never held (``extra={UNHELD: True}``): what must
#: be said when it comes, such as a long run's estimate, passes a hold.
UNHELD = "viscore_unheld"


class _Hold(logging.Filter):
    """Keeps, and stops, the toolkit's records one thread makes; any other record passes."""

    def __init__(self) -> None:
        super().__init__()
        self.thread = threading.get_ident()
        self.records: list[logging.LogRecord] = []
        self._seen: set[int] = set()  # a record reaches several handlers: kept once

    def filter(self, record: logging.LogRecord) -> bool:
        if record.thread != self.thread or getattr(record, UNHELD, False) or not (
                record.name == _PREFIX or record.name.startswith(_PREFIX + ".")):
            return True
        if id(record) not in self._seen:
            self._seen.add(id(record))
            self.records.append(record)
        return False


def _filterers() -> list[logging.Filterer]:
    """Where a hold stops records: the toolkit's loggers, and the root's handlers.

    A logger's filters see the records made at that logger (module loggers
    exist once their module is imported); the root's handlers (and the
    handler of last resort) see those of a logger made during the block too.
    """
    found: list[logging.Filterer] = [logging.getLogger(_PREFIX)]
    for name, logger in list(logging.root.manager.loggerDict.items()):
        if name.startswith(_PREFIX + ".") and isinstance(logger, logging.Logger):
            found.append(logger)
    found += logging.getLogger().handlers
    if logging.lastResort is not None:
        found.append(logging.lastResort)
    return found


@contextlib.contextmanager
def held_records() -> Iterator[list[logging.LogRecord]]:
    """Hold back, for the block, the records this thread logs through the toolkit's loggers.

    Yields the list the records are collected in (in the order they were
    made); after the block they are the caller's to :func:`release` or
    :func:`report_parts`. Records of other threads, and of loggers outside
    ``viscore``, pass as usual; so do records of a logger made during the
    block that reach only handlers of its own (none of ours has any), and
    records marked :data:`UNHELD`. A hold inside another sees the records first.

    Examples
    --------
    >>> log = logging.getLogger("viscore.example"); log.setLevel(logging.INFO)
    >>> with held_records() as records:
    ...     log.warning("said later")
    >>> [r.getMessage() for r in records]
    ['said later']
    """
    hold = _Hold()
    filterers = _filterers()
    for filterer in filterers:
        filterer.filters.insert(0, hold)  # before any other filter, an outer hold's included
    try:
        yield hold.records
    finally:
        for filterer in filterers:
            with contextlib.suppress(ValueError):
                filterer.filters.remove(hold)


def call_held(func: Callable[..., T], /, *args, **kwargs
              ) -> tuple[T, list[logging.LogRecord]]:
    """``func(*args, **kwargs)`` and the records it logged, held back (:func:`held_records`)
    for the caller to say; on an error the records are said as they were, then the error
    raised.

    Examples
    --------
    >>> log = logging.getLogger("viscore.example"); log.setLevel(logging.INFO)
    >>> value, records = call_held(lambda: log.warning("said later") or 3)
    >>> value, [r.getMessage() for r in records]
    (3, ['said later'])
    """
    records: list[logging.LogRecord] = []
    try:
        with held_records() as records:
            return func(*args, **kwargs), records
    except BaseException:
        release(list(records))
        raise


def release(records: Sequence[logging.LogRecord]) -> None:
    """Pass held records on to their loggers' handlers, as if just logged."""
    for record in records:
        logging.getLogger(record.name).handle(record)


def report_parts(held: Sequence[tuple[int, logging.LogRecord]], parts: int,
                 what: str = "nodes", label: str = "hierarchy", one: str | None = None,
                 names: Mapping[int, str] | None = None) -> None:
    """Say each distinct message of the held records once, with the parts that gave it.

    Parameters
    ----------
    held : sequence of (int, logging.LogRecord)
        Each record with the id of the part (node) whose build logged it.
    parts : int
        How many parts there are.
    what, label : str, optional
        The parts' name and the prefix of each line.
    one : str, optional
        One part's name (default: ``what`` without its final "s").
    names : mapping of int -> str, optional
        Each part's own name (a mesh's file and node). Texts that differ
        only by it, each part naming itself ("GLTF_19 is not closed", "GLTF_22
        is not closed"), are one text, said with "each of them" in its place.

    Notes
    -----
    Texts that differ only by their numbers are one text too, each number said
    as the range of those it stood for ("walls of 0.004 to 0.01"). A text that
    begins with ``label`` and a colon loses that beginning (the line starts
    with the label already). One record per distinct text, in the order the
    texts first came, at the
    highest level that text came at, through the logger that made it first:
    ``hierarchy: 29 of 57 nodes: <text>`` when several parts gave it,
    ``hierarchy node 12: <text>`` when one did (``label: <text>`` when ``names`` gives
    its name and the text holds it, ``label node <name>: <text>`` when it does not).

    Examples
    --------
    >>> log = logging.getLogger("viscore.example"); log.setLevel(logging.INFO)
    >>> with held_records() as records:
    ...     log.warning("open mesh")
    ...     log.warning("open mesh")
    ...     log.warning("tiny")
    >>> with held_records() as said:
    ...     report_parts(list(zip([0, 1, 1], records)), 3)
    >>> [r.getMessage() for r in said]
    ['hierarchy: 2 of 3 nodes: open mesh', 'hierarchy node 1: tiny']
    """
    groups: dict[str, list] = {}
    for part, record in held:
        text = record.getMessage()
        if text.startswith(label + ": "):  # the label once: not "aabb-skins: ... aabb-skins:"
            text = text[len(label) + 2:]
        own = (names or {}).get(part)
        key, numbers = _template(text.replace(own, _EACH) if own else text)
        group = groups.setdefault(key, [record, set(), []])
        if record.levelno > group[0].levelno:
            group[0] = record
        group[1].add(part)
        group[2].append(numbers)
    for key, (record, which, numbers) in groups.items():
        logger = logging.getLogger(record.name)
        text = _filled(key, numbers)
        if len(which) == 1:
            part = next(iter(which))
            own = (names or {}).get(part)
            text = text.replace(_EACH, own) if own else text
            if own and own in text:  # the text names its part: not "mesh 6: ...:Cube.001: ..."
                logger.log(record.levelno, "%s: %s", label, text)
            else:
                logger.log(record.levelno, "%s %s %s: %s", label,
                           what.rstrip("s") if one is None else one,
                           own or str(part), text)
        else:
            logger.log(record.levelno, "%s: %d of %d %s: %s", label, len(which), parts, what,
                       text.replace(_EACH, "each of them"))


#: Fields of a record kept by :func:`portable` (its message is formatted first).
_PORTABLE_FIELDS = ("name", "levelno", "levelname", "pathname", "lineno", "funcName",
                    "created", "msecs", "thread", "threadName", "process", "processName")


def portable(records: Sequence[logging.LogRecord]) -> list[dict]:
    """Held records as plain dicts that pickle (a worker process hands them to its parent).

    Each record's message is formatted here (``msg``, with ``args`` None):
    arguments that do not pickle, or that a process alone can format, never
    travel. :func:`restored` makes records of them again.

    Examples
    --------
    >>> log = logging.getLogger("viscore.example"); log.setLevel(logging.INFO)
    >>> with held_records() as records:
    ...     log.warning("%d boxes", 3)
    >>> [r.getMessage() for r in restored(portable(records))]
    ['3 boxes']
    """
    return [{**{k: getattr(r, k, None) for k in _PORTABLE_FIELDS}, "msg": r.getMessage(),
             "args": None} for r in records]


def restored(items: Sequence[Mapping]) -> list[logging.LogRecord]:
    """Records again from :func:`portable`'s dicts (for :func:`release` or :func:`report_kinds`)."""
    return [logging.makeLogRecord(dict(item)) for item in items]


def report_kinds(records: Sequence[logging.LogRecord], *, labels: Sequence[str] = (),
                 level: int = logging.WARNING, what: str = "times") -> int:
    """Say each kind of record at ``level`` or above once, with how many times it came.

    Parameters
    ----------
    records : sequence of logging.LogRecord
        Held records (:func:`held_records`, :func:`restored`), in the order
        they were made; those under ``level`` are not said.
    labels : sequence of str, optional
        Prefixes that do not make a kind of their own: a text that begins
        with one of them and a colon is grouped by the rest of it, and its
        line names every label that gave it (the same warning about the
        city's ground from ``aabb-skins`` and from ``solid-frusta``, whose
        boxes come from aabb-skins, is one line).
    level : int, optional
        The lowest level said (default WARNING).
    what : str, optional
        The word after the count (default "times").

    Returns
    -------
    int
        The lines said.

    Notes
    -----
    One record per kind, in the order the kinds first came, at the highest
    level that kind came at, through the logger that made it first: the text
    as it was when it came once, else ``<labels>: <text> (<n> <what>)``. Texts
    that differ only by their numbers are one kind, each number said as the
    range of those it stood for.

    Examples
    --------
    >>> log = logging.getLogger("viscore.example"); log.setLevel(logging.INFO)
    >>> with held_records() as records:
    ...     log.warning("a: ground too thin")
    ...     log.warning("b: ground too thin")
    ...     log.info("a: a detail")
    ...     log.warning("open mesh")
    >>> with held_records() as said:
    ...     _ = report_kinds(records, labels=("a", "b"))
    >>> [r.getMessage() for r in said]
    ['a, b: ground too thin (2 times)', 'open mesh']
    """
    groups: dict[str, list] = {}
    for record in records:
        if record.levelno < level:
            continue
        text = record.getMessage()
        label = None
        for candidate in labels:
            if text.startswith(candidate + ": "):
                label, text = candidate, text[len(candidate) + 2:]
                break
        key, numbers = _template(text)
        group = groups.setdefault(key, [record, [], 0, []])
        if record.levelno > group[0].levelno:
            group[0] = record
        if label is not None and label not in group[1]:
            group[1].append(label)
        group[2] += 1
        group[3].append(numbers)
    for key, (record, names, count, numbers) in groups.items():
        logger = logging.getLogger(record.name)
        if count == 1:
            logger.log(record.levelno, "%s", record.getMessage())
        else:
            prefix = ", ".join(names) + ": " if names else ""
            logger.log(record.levelno, "%s%s (%d %s)", prefix, _filled(key, numbers), count,
                       what)
    return len(groups)
