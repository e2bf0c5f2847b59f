"""Files read bounded: regular files only, sizes checked before reading, references confined.

Every reader of :mod:`viscore.exchange` (and the level loader) opens its files
here: the file named by the user and every file it references (an OBJ's
material library and textures, a glTF's buffers and images, a Godot scene's
external occluders). Three rules hold for all of them:

- only a regular file is read: a folder, a FIFO, a device or a socket is
  refused by its kind without being read, and a FIFO never blocks (the file
  is opened non-blocking and checked with ``fstat`` on the open descriptor,
  so one swapped in after a check is refused too); a loop of symbolic links
  is named as one;
- the size is checked before anything is read: against the memory a parse
  of it needs (:func:`viscore._validate.check_memory`), or against the size
  its referrer declares (a glTF buffer's ``byteLength``), or, for an image,
  against the bytes its pixels can take; a file much longer than what it
  holds (padded with gigabytes) is refused, and only the declared bytes are
  read;
- a referenced file resolves inside the folder of the file that references
  it (symbolic links followed): a reference that escapes is never opened.

A referenced file is refused with one :class:`~viscore.InputError` naming the
referring file and the reference. Readers built on trimesh swallow some
failures of a referenced file (an OBJ's material library, a glTF image), so
:class:`FolderResolver` records each refusal and the caller raises it once
trimesh returns (:meth:`FolderResolver.raise_refusal`).
"""

from __future__ import annotations

import contextvars
import errno
import logging
import os
import stat
from collections.abc import Mapping
from pathlib import Path
from typing import BinaryIO
from urllib.parse import unquote

import trimesh

from .._validate import InputError, _human_bytes, check_memory

__all__ = ["trimesh_loading", "open_regular", "read_regular", "read_declared", "refuse_path",
           "file_kind", "FolderResolver", "UriOutsideFolder"]

_log = logging.getLogger(__name__)

#: Peak bytes of memory per byte of mesh file while trimesh parses it and the
#: mesh is validated (measured with trimesh 5.2 on a 1.3M-face icosphere:
#: OBJ 6.5, PLY 10, STL 9, GLB 7.5, OFF 17 x the file size in peak RSS).
PARSE_BYTES_PER_FILE_BYTE = 20
#: Trailing bytes of a text file looked at for NUL bytes before it is read.
TEXT_TAIL_BYTES = 4096
#: A file whose size the kernel reports as 0 (``/proc`` files) is read up to this.
UNSIZED_READ_LIMIT = 64 << 20
#: Bytes a referenced file may hold past the size its referrer declares (the glTF
#: specification pads chunks to 4 bytes; tools align to pages), before it is refused
#: as padded.
DECLARED_SLACK = 4096
#: Largest referenced file without a declared size that is not an image PIL reads
#: (a material library, a texture of a format nothing here decodes), bytes.
MAX_UNDECLARED_BYTES = 256 << 20
#: Bytes an image file may hold beyond its pixels (bit depth x bands x width x
#: height): headers, palettes, colour profiles, metadata, and a format's worst
#: case of growth on incompressible data, which is far less.
IMAGE_OVERHEAD_BYTES = 16 << 20
#: File name suffixes of images (textures referenced by OBJ materials or glTF).
IMAGE_SUFFIXES = frozenset({"png", "jpg", "jpeg", "webp", "bmp", "tga", "gif", "tif", "tiff",
                            "ktx", "ktx2", "dds", "hdr", "exr"})


#: True while trimesh parses a file for us: its log records (INFO/WARNING) are then
#: demoted to DEBUG on our logger, so a failing load ends in one error line, not a
#: trail of trimesh's.
trimesh_loading = contextvars.ContextVar("viscore_mesh_loading", default=False)


class _DemoteWhileLoading(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        if not trimesh_loading.get():
            return True
        _log.debug("trimesh: %s", record.getMessage())
        return False


logging.getLogger("trimesh").addFilter(_DemoteWhileLoading())


def refuse_path(path: str | os.PathLike, label: str, exc: OSError) -> InputError:
    """One-line :class:`InputError` saying why a path cannot be opened."""
    if isinstance(exc, FileNotFoundError):
        if os.path.islink(path):
            return InputError(f"{label}: a broken symbolic link (to {os.readlink(path)!r})")  # type: ignore[type-var]
        return InputError(f"{label}: no such file")
    if isinstance(exc, NotADirectoryError):
        return InputError(f"{label}: a component of the path is a file, not a folder")
    if isinstance(exc, PermissionError):
        return InputError(f"{label}: permission denied")
    if exc.errno == errno.ELOOP:
        return InputError(f"{label}: a loop of symbolic links")
    if exc.errno == errno.ENAMETOOLONG:
        return InputError(f"{label}: the file name is too long")
    return InputError(f"{label}: cannot open ({exc.strerror or exc})")


def file_kind(mode: int) -> str:
    """``'a directory'``, ``'a named pipe (FIFO)'``, ... for a ``st_mode`` that is not a file."""
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def open_regular(path: str | os.PathLike, label: str, *, what: str = "a file") -> BinaryIO:
    """A regular file opened for binary reading; anything else refused without reading it.

    Parameters
    ----------
    path : path
    label : str
        Names the file in messages (the path as the user wrote it, or
        ``scene.tscn -> res://a.occ`` for a reference).
    what : str, optional
        What was expected, for the message (``'a mesh file'``).

    Returns
    -------
    file : binary file object
        Blocking reads from here on (the descriptor is switched back after the
        ``fstat`` check). The caller closes it.

    Raises
    ------
    InputError
        The path is missing, a broken link, a loop of links, not a regular
        file (folder, FIFO, device, socket), or cannot be opened.
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise refuse_path(path, label, exc) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise InputError(f"{label}: {file_kind(mode)}, expected {what}")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def _size(fh: BinaryIO) -> int:
    return os.fstat(fh.fileno()).st_size


def read_regular(path: str | os.PathLike, label: str, *, what: str = "a file",
                 bytes_per_byte: float = 1.0, empty_ok: bool = False,
                 text: bool = False) -> bytes:
    """The bytes of a regular file, its size checked against the memory limit first.

    Parameters
    ----------
    path : path
    label : str
        Names the file in messages.
    what : str, optional
        What was expected (``'a mesh file'``).
    bytes_per_byte : float, optional
        Peak memory of the caller's parse per byte of file: the file is
        refused before it is read when ``size x bytes_per_byte`` passes
        :func:`viscore._validate.check_memory`'s limit. Default 1.
    empty_ok : bool, optional
        Return ``b''`` for an empty file instead of refusing it.
    text : bool, optional
        The file is text, which never holds a NUL byte: one in its last
        :data:`TEXT_TAIL_BYTES` (a text file padded with zeros) refuses it
        before the rest is read.

    Raises
    ------
    InputError
        As :func:`open_regular`; the file is empty, over the memory limit,
        grows while it is read, or cannot be read.
    """
    with open_regular(path, label, what=what) as fh:
        size = _size(fh)
        if text and size:
            tail = min(size, TEXT_TAIL_BYTES)
            try:
                padded = b"\0" in os.pread(fh.fileno(), tail, size - tail)
            except OSError as exc:
                raise InputError(f"{label}: cannot read ({exc.strerror or exc})") from None
            if padded:
                raise InputError(f"{label}: NUL bytes at its end ({_human_bytes(size)} file): "
                                 f"padded, or not {what} (not read)")
        check_memory(size * bytes_per_byte, f"{label} ({_human_bytes(size)} file)")
        limit = size if size > 0 else UNSIZED_READ_LIMIT
        try:
            data = fh.read(limit + 1)
        except MemoryError:
            raise InputError(f"{label}: not enough memory to read this file") from None
        except OSError as exc:
            raise InputError(f"{label}: cannot read ({exc.strerror or exc})") from None
    if len(data) > limit:
        raise InputError(f"{label}: the file grew while being read (or reports no size and "
                         f"holds more than {_human_bytes(UNSIZED_READ_LIMIT)})")
    if not data and not empty_ok:
        raise InputError(f"{label}: the file is empty")
    return data


def _read_exactly(fh: BinaryIO, size: int, label: str) -> bytes:
    try:
        data = fh.read(size)
    except MemoryError:
        raise InputError(f"{label}: not enough memory to read this file") from None
    except OSError as exc:
        raise InputError(f"{label}: cannot read ({exc.strerror or exc})") from None
    if len(data) != size:
        raise InputError(f"{label}: the file shrank while being read")
    return data


def _check_declared(size: int, declared: int, label: str, what: str) -> None:
    if size < declared:
        raise InputError(f"{label}: {_human_bytes(size)} ({size:,} bytes), shorter than the "
                         f"{declared:,} bytes {what} declares")
    if size > declared + DECLARED_SLACK:
        raise InputError(f"{label}: {_human_bytes(size)}, but {what} declares {declared:,} "
                         f"bytes: {size - declared:,} bytes more than it holds (a padded or "
                         "wrong file; not read)")


def read_declared(fh: BinaryIO, declared: int, label: str, *, what: str) -> bytes:
    """The first ``declared`` bytes of an open file whose referrer declares its size.

    Refused when the file is shorter, or longer by more than
    :data:`DECLARED_SLACK` bytes (a file padded to gigabytes is not read).
    """
    _check_declared(_size(fh), declared, label, what)
    check_memory(declared, f"{label} ({_human_bytes(declared)} declared by {what})")
    return _read_exactly(fh, declared, label)


def _image_bytes_needed(fh: BinaryIO) -> tuple[int, str] | None:
    """Most bytes an image file needs, from its header (PIL reads only the header), and
    its size as ``'W x H'``; None when PIL does not recognise it."""
    try:
        from PIL import Image
    except ImportError:  # pragma: no cover - pillow comes with trimesh's extras
        return None
    try:
        with Image.open(fh) as image:
            width, height = image.size
            bits = {"1": 1, "I;16": 16, "I;16B": 16, "I;16L": 16, "I": 32, "F": 32}.get(
                image.mode, 8)
            bands = len(image.getbands())
            frames = max(1, int(getattr(image, "n_frames", 1) or 1))
    except Exception:  # noqa: BLE001 - PIL raises many types on what it cannot read
        return None
    finally:
        fh.seek(0)
    raw = width * height * bands * bits * frames // 8
    return raw + IMAGE_OVERHEAD_BYTES, f"{width} x {height}"


def _read_reference(fh: BinaryIO, name: str, label: str, declared: int | None) -> bytes:
    """The bytes of an opened referenced file, bounded by what it can hold."""
    size = _size(fh)
    if declared is not None:
        return read_declared(fh, declared, label, what="its referrer")
    suffix = Path(name).suffix.lower().lstrip(".")
    if suffix in IMAGE_SUFFIXES:
        needed = _image_bytes_needed(fh)
        if needed is not None and size > needed[0]:
            raise InputError(f"{label}: a {needed[1]} image in a {_human_bytes(size)} file; "
                             f"its pixels need at most {_human_bytes(needed[0])} (a padded or "
                             "wrong file; not read)")
        limit = MAX_UNDECLARED_BYTES if needed is None else needed[0]
    else:
        limit = MAX_UNDECLARED_BYTES
    if size > limit:
        raise InputError(f"{label}: {_human_bytes(size)}, more than the "
                         f"{_human_bytes(limit)} a referenced file of its kind may hold "
                         "(not read)")
    check_memory(size, f"{label} ({_human_bytes(size)} file)")
    return _read_exactly(fh, size, label)


class UriOutsideFolder(Exception):
    """A reference that resolves outside the folder of the referring file (never read)."""

    def __init__(self, uri: str):
        super().__init__(uri)
        self.uri = uri


def _quoted(value: object, limit: int = 120) -> str:
    """``repr`` of a name, URI or value from a file, cut to about ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


def _absolute(name: str) -> bool:
    """A URI with a scheme, or an absolute path (POSIX, Windows drive or UNC)."""
    return ("://" in name or name.startswith(("file:", "/", "\\")) or Path(name).is_absolute()
            or (len(name) > 1 and name[1] == ":" and name[0].isalpha()))


class FolderResolver(trimesh.resolvers.Resolver):
    """trimesh's resolver for the files one file references, confined and bounded.

    Reads the reference as written or percent-decoded (glTF URIs are
    percent-encoded), only when both resolve inside the folder (symbolic links
    followed); an absolute path, a URI with a scheme or one that climbs out of
    the folder is never opened, nor is its last component looked for inside
    (trimesh's own resolver does that). Reads only regular files, bounded as
    the module docstring says. A reference outside the folder raises
    :class:`UriOutsideFolder` and is recorded in ``outside``; every refusal
    (:class:`InputError`) is recorded in ``refusals`` too, since trimesh
    swallows some (:meth:`raise_refusal`).

    Parameters
    ----------
    path : path
        The referring file; its folder (the folder of the file it links to,
        for a symbolic link) is the root.
    label : str
        Names the referring file in messages.
    declared : mapping str -> int, optional
        Sizes the referring file declares, by reference (a glTF buffer's
        ``uri`` -> ``byteLength``).
    """

    def __init__(self, path: str | os.PathLike, label: str, *,
                 declared: Mapping[str, int] | None = None) -> None:
        try:  # beside the file a symbolic link names, as trimesh's resolver looks
            self.root = Path(path).resolve().parent
        except (OSError, RuntimeError):
            self.root = Path(os.path.abspath(path)).parent
        self.label = label
        self.declared = dict(declared or {})
        self.outside: list[str] = []
        self.refusals: list[InputError] = []

    def keys(self):  # pragma: no cover - trimesh asks only for named files
        return iter(())

    def write(self, name, data):  # pragma: no cover - readers never write
        raise InputError(f"{self.label}: writing {name!r} beside it is not allowed")

    def namespaced(self, namespace: str) -> FolderResolver:  # pragma: no cover
        return self

    def _refuse(self, message: str) -> InputError:
        error = InputError(message)
        self.refusals.append(error)
        return error

    def get(self, name: str) -> bytes:
        text = str(name).strip()
        where = f"{self.label}: {_quoted(text)}"
        try:
            root = self.root.resolve()
            targets = []  # type: ignore[var-annotated]
            for candidate in dict.fromkeys((text, unquote(text))):
                if "\0" in candidate:
                    raise self._refuse(f"{where}: a NUL byte in the name")
                if _absolute(candidate):
                    targets = []
                    break
                targets.append((candidate, (root / candidate).resolve()))
            if not targets or not all(t.is_relative_to(root) for _, t in targets):
                self.outside.append(text)
                raise UriOutsideFolder(text)
            for candidate, target in targets:
                if os.path.lexists(target):
                    with open_regular(target, where) as fh:
                        return _read_reference(fh, candidate, where, self.declared.get(text))
        except InputError as exc:
            if exc not in self.refusals:
                self.refusals.append(exc)
            raise
        except RuntimeError:  # pathlib's "Symlink loop" (Python 3.11)
            raise self._refuse(f"{where}: a loop of symbolic links") from None
        except OSError as exc:
            raise self._refuse(f"{where}: cannot be read "
                               f"({' '.join(str(exc.strerror or exc).split())[:120]})") from None
        raise FileNotFoundError(text)

    def raise_refusal(self) -> None:
        """Raise the first refusal trimesh may have swallowed, if any."""
        if self.refusals:
            raise self.refusals[0]

