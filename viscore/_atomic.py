"""Atomic output files: a write lands whole or not at all, with the mode ``open`` gives.

Shared by the command line (tables, meshes, reports) and the figure module of
:mod:`viscore.metrics` (plots written beside a study).
"""

from __future__ import annotations

import contextlib
import errno
import glob
import os
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

from ._validate import InputError

__all__ = ["write_atomic", "check_output_path", "file_mode", "swap_folder", "FileSet",
           "fsync_path", "lock_exclusive", "LockedFolder"]

#: ``renameat2`` arguments (Linux ``<fcntl.h>``, ``<linux/fs.h>``).
_AT_FDCWD, _RENAME_EXCHANGE = -100, 2


def _umask() -> int:
    """The process umask, read without changing it where Linux allows."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # pragma: no cover - not Linux: read by setting and restoring
    os.umask(mask)
    return mask


def file_mode() -> int:
    """Mode of a new file under the process umask: what ``open(path, "w")`` gives.

    ``tempfile.mkstemp`` makes its files ``0o600``; a writer that moves such a
    file into place sets this mode on it first.

    Examples
    --------
    >>> 0 <= file_mode() <= 0o666
    True
    """
    return 0o666 & ~_umask()


def check_output_path(path: str | os.PathLike) -> Path:
    """Refuse, before any work, an output file path that cannot be written.

    The folder must exist (it is never created: a typo must not silently make
    a tree) and be a folder, and the path must not be a directory.

    Raises
    ------
    InputError
        One line naming the path and the problem.
    """
    from viscore import InputError

    path = Path(path)
    parent = path.parent
    if path.name in ("", ".", ".."):
        raise InputError(f"{path}: expected a file name, got a folder")
    try:
        st = os.stat(parent)
    except FileNotFoundError:
        raise InputError(f"{path}: the folder {str(parent)!r} does not exist "
                         "(it is not created)") from None
    except NotADirectoryError:
        raise InputError(f"{path}: a component of the folder {str(parent)!r} is a file") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot reach the folder {str(parent)!r} "
                         f"({exc.strerror or exc})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(f"{path}: {str(parent)!r} is not a folder")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, expected a file path")
    return path


def write_atomic(path: str | os.PathLike, data: bytes, *, parents: bool = False) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename.

    A killed process leaves either the old file or the new one, never half,
    and a failed write leaves nothing new at ``path``. The file gets the mode
    a plain ``open(path, "w")`` would give: an existing file keeps its mode, a
    new one gets ``0o666 & ~umask``.

    Parameters
    ----------
    path : path
        The output file.
    data : bytes
        Its whole content.
    parents : bool, optional
        Create missing parent folders (for folders the caller owns, such as a
        study's ``occluders/``). Default False: a missing folder is an error,
        never silently created.

    Raises
    ------
    InputError
        If the folder does not exist (and ``parents`` is False), or ``path``
        is a directory.
    OSError
        If writing fails (permissions, full disk); its ``filename`` is
        ``path``, never the internal temporary file.
    """
    path = Path(path)
    if parents:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(path.parent)) from None
    check_output_path(path)
    try:
        mode = stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        mode = file_mode()
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            os.fchmod(fh.fileno(), mode)
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:  # name the user's path, not the temporary file
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
    try:  # make the rename durable; some filesystems cannot fsync a folder
        dir_fd = os.open(path.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)


def _exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths in one step (Linux ``renameat2(RENAME_EXCHANGE)``).

    Returns False where the call or the flag is not supported (not Linux, an
    old kernel or C library, a filesystem without it); other failures raise
    OSError naming ``b``.
    """
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                          ctypes.c_uint]
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def swap_folder(new: str | os.PathLike, target: str | os.PathLike) -> None:
    """Put the folder ``new`` at the existing folder ``target``; the old one goes to ``new``.

    Where Linux allows (``renameat2`` with ``RENAME_EXCHANGE``) the two are
    exchanged in one step: a reader of ``target`` sees the old files or the
    new ones, never a mix, and a killed process leaves one or the other.
    Elsewhere two renames: killed between them, ``target`` is missing (none
    of the files, never a mix) and the old folder is at ``new``. Both paths
    must be in one filesystem (siblings are); the caller removes ``new``.

    Raises
    ------
    OSError
        If the folders cannot be renamed; its ``filename`` is ``target``.
    """
    new, target = Path(new), Path(target)
    if _exchange(new, target):
        return
    old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", suffix=".tmp", dir=target.parent))
    try:
        os.replace(target, old)  # an empty folder is replaced by a folder
        try:
            os.replace(new, target)
        except OSError:
            os.replace(old, target)  # put the old folder back
            raise
        os.replace(old, new)  # the old files where the caller removes them
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(target)) from None
    finally:
        if old.is_dir() and not any(old.iterdir()):
            old.rmdir()


class FileSet:
    """Files written into one folder as a set, all or none: ``with FileSet(folder) as fs:``.

    Each :meth:`write` lands in a hidden temporary folder inside ``folder``
    (``.viscore-set-*.tmp``, on the same filesystem); when the ``with`` block
    ends without an exception, every file is moved into place, and if a move
    fails the ones already moved are undone (a file they replaced is put
    back). On any exception, in the block or while moving, none of the new
    files is left in ``folder`` and files it held before keep their content.
    The temporary folder is always removed. Use it where a set of files sits
    beside the user's own (a hierarchy's JSON and node meshes beside OUT);
    a folder of our own is swapped whole (:func:`swap_folder`).

    Parameters
    ----------
    folder : path
        An existing folder (it is not created).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     with FileSet(d) as files:
    ...         _ = files.write("a.txt", b"1")
    ...         _ = files.write("b.txt", b"2")
    ...     print(sorted(p.name for p in Path(d).iterdir()))
    ['a.txt', 'b.txt']
    >>> with tempfile.TemporaryDirectory() as d:
    ...     try:
    ...         with FileSet(d) as files:
    ...             _ = files.write("a.txt", b"1")
    ...             raise OSError("disk full")
    ...     except OSError:
    ...         pass
    ...     print(list(Path(d).iterdir()))
    []
    """

    def __init__(self, folder: str | os.PathLike) -> None:
        self.folder = Path(folder)
        self._names: list[str] = []
        self._tmp: Path | None = None

    def __enter__(self) -> FileSet:
        try:
            self._tmp = Path(tempfile.mkdtemp(prefix=".viscore-set-", suffix=".tmp",
                                              dir=self.folder))
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror or str(exc), str(self.folder)) from None
        return self

    def write(self, name: str, data: bytes) -> Path:
        """Stage ``data`` as the file ``name`` of the folder; returns the path it will have.

        Raises
        ------
        ValueError
            ``name`` is not a plain file name, or was written already.
        OSError
            Writing fails; its ``filename`` is the final path.
        """
        if self._tmp is None:
            raise RuntimeError("FileSet.write outside its with block")
        if not name or Path(name).name != name or name in (".", "..") or name in self._names:
            raise ValueError(f"expected a new file name without a folder, got {name!r}")
        target = self.folder / name
        try:
            mode = stat.S_IMODE(os.stat(target).st_mode)  # an existing file keeps its mode
        except OSError:
            mode = file_mode()
        try:
            with open(self._tmp / name, "wb") as fh:
                os.fchmod(fh.fileno(), mode)
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror or str(exc), str(target)) from None
        self._names.append(name)
        return target

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is None:
                self._commit()
        finally:
            shutil.rmtree(self._tmp, ignore_errors=True)  # type: ignore[arg-type]
            self._tmp = None

    def _commit(self) -> None:
        """Move every staged file into place; on a failure, undo the moves made."""
        moved: list[tuple[Path, Path | None]] = []  # (target, its old file kept aside)
        for name in self._names:
            target = self.folder / name
            try:
                old = self._keep_old(target)
                os.replace(self._tmp / name, target)  # type: ignore[operator]
            except OSError as exc:
                self._undo(moved)
                raise OSError(exc.errno, exc.strerror or str(exc), str(target)) from None
            moved.append((target, old))
        fsync_path(self.folder)

    def _keep_old(self, target: Path) -> Path | None:
        """A hard link to the file at ``target`` in the temporary folder, or None."""
        if not os.path.isfile(target) or os.path.islink(target):
            return None
        old = self._tmp / f".old-{target.name}"  # type: ignore[operator]
        try:
            os.link(target, old)
        except OSError:  # a filesystem without hard links: the undo removes the new file
            return None
        return old

    @staticmethod
    def _undo(moved: list[tuple[Path, Path | None]]) -> None:
        for target, old in reversed(moved):
            try:
                if old is not None:
                    os.replace(old, target)
                else:
                    target.unlink(missing_ok=True)
            except OSError:
                pass


def fsync_path(path: str | os.PathLike) -> None:
    """Flush a file, or the renames in a folder, to disk where the filesystem allows."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


#: Attempts of :func:`lock_exclusive` on a path that keeps being replaced.
_LOCK_ATTEMPTS = 5


def lock_exclusive(path: str | os.PathLike, busy: str) -> int:
    """Take an exclusive advisory lock on ``path`` for this process; returns its descriptor.

    ``path`` is a lock file (created if missing) or a folder (locked as it is,
    nothing is created in it). The lock is ``fcntl.flock(LOCK_EX | LOCK_NB)``:
    it is released when the descriptor is closed or the process dies, SIGKILL
    included. A path replaced while the lock was being taken (another process
    renamed a folder over it) is locked again on what it now names.

    Parameters
    ----------
    path : path-like
        The lock file or folder.
    busy : str
        The one-line message when another process holds the lock.

    Returns
    -------
    int
        The descriptor; close it to release the lock.

    Raises
    ------
    InputError
        ``busy``, when another process holds the lock.
    OSError
        When the path cannot be opened or locked; its ``filename`` is ``path``.
    """
    import fcntl

    path = Path(path)
    for _ in range(_LOCK_ATTEMPTS):
        try:
            flags = os.O_RDONLY | os.O_DIRECTORY if path.is_dir() else os.O_RDWR | os.O_CREAT
            fd = os.open(path, flags | os.O_CLOEXEC, 0o666)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(path)) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            same = os.path.samestat(os.fstat(fd), os.stat(path))
        except BlockingIOError:
            os.close(fd)
            raise InputError(busy) from None
        except FileNotFoundError:  # renamed away while we locked it: lock what is there now
            os.close(fd)
            continue
        except OSError as exc:
            os.close(fd)
            raise OSError(exc.errno, f"cannot lock ({exc.strerror})", str(path)) from None
        if same:
            return fd
        os.close(fd)
    raise InputError(busy)


class LockedFolder:
    """An output folder held by this process alone, its files written as one set.

    ``with LockedFolder(path, busy=...) as folder:`` makes the folder if
    missing (its parent must exist; a link to a folder stands for the
    folder), takes an exclusive advisory lock (:func:`lock_exclusive`) on
    the folder itself, or with ``lock_file`` on that file inside it, and
    puts right what a killed run of ours left: a set staged beside the
    folder by :meth:`write_set` (``.NAME.TAG-*.tmp``, or the old set
    :func:`swap_folder` moved to ``.NAME.old-*.tmp``) is emptied, the set's
    own files removed and any other file moved back into the folder; and
    half-written copies of the set's files inside it (``.STEM.*.SUFFIX``)
    are removed. Leaving releases the lock; when the block (or entering)
    failed, the folder goes too if this call made it and it is empty.

    Parameters
    ----------
    path : path
        The folder.
    busy : str
        The one line when another process holds the lock.
    lock_file : str, optional
        Lock this file in the folder (created, and left there) instead of
        the folder itself.
    outputs : iterable of str, optional
        The file names :meth:`write_set` may write: the set.
    tag : str, optional
        Names the staging folders beside the folder (default ``"set"``).

    Examples
    --------
    >>> with tempfile.TemporaryDirectory() as d:
    ...     out = Path(d) / "out"
    ...     with LockedFolder(out, busy="busy", outputs=("a.txt",)) as folder:
    ...         folder.write_set({"a.txt": b"1"})
    ...     print(sorted(p.name for p in Path(d).iterdir()), (out / "a.txt").read_text())
    ['out'] 1
    """

    def __init__(self, path: str | os.PathLike, *, busy: str, lock_file: str | None = None,
                 outputs: Iterable[str] = (), tag: str = "set") -> None:
        self.label = Path(path)
        self.path = Path(os.path.realpath(path))
        self._busy = busy
        self._lock_file = lock_file
        self._outputs = tuple(outputs)
        self._tag = tag
        self._fd: int | None = None
        self._created = False

    def __enter__(self) -> LockedFolder:
        self._created = not os.path.lexists(self.path)
        try:
            self.path.mkdir(exist_ok=True)
        except OSError as exc:
            raise OSError(exc.errno, exc.strerror, str(self.label)) from None
        try:
            lock = self.path if self._lock_file is None else self.path / self._lock_file
            self._fd = lock_exclusive(lock, busy=self._busy)
            self._sweep()  # (when another process holds it, the folder is that run's)
        except BaseException:
            self._leave(failed=True)
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self._leave(failed=exc_type is not None)

    def _leave(self, *, failed: bool) -> None:
        try:
            if failed and self._created:
                with contextlib.suppress(OSError):  # only if empty: never a file of a run
                    self.path.rmdir()
        finally:
            if self._fd is not None:
                os.close(self._fd)  # releases the lock
                self._fd = None

    def _staging(self) -> list[Path]:
        """Temporary sibling folders of ours: a new set not yet in place, or an old one."""
        stem = glob.escape(f".{self.path.name}")
        return [p for kind in (self._tag, "old")
                for p in self.path.parent.glob(f"{stem}.{kind}-*.tmp")]

    def _sweep(self) -> None:
        """Remove what a killed run of ours left: sibling sets, temporary files inside."""
        for folder in self._staging():
            self._settle(folder)
        for name in self._outputs:  # half-written copies of the set's files, in the folder
            stem, _, suffix = name.rpartition(".")
            for stale in self.path.glob(f".{glob.escape(stem)}.*.{glob.escape(suffix)}"):
                if stale.is_file() and not stale.is_symlink():
                    stale.unlink(missing_ok=True)

    def _settle(self, folder: Path) -> None:
        """Empty a staging folder: our files go, anything else back into the folder."""
        if folder.is_symlink() or not folder.is_dir():
            return
        for entry in folder.iterdir():
            if entry.name in self._outputs and (entry.is_symlink() or not entry.is_dir()):
                entry.unlink(missing_ok=True)
            elif not os.path.lexists(self.path / entry.name):  # a file the user kept there
                with contextlib.suppress(OSError):
                    os.rename(entry, self.path / entry.name)
        with contextlib.suppress(OSError):
            folder.rmdir()

    def write_set(self, files: Mapping[str, bytes | Callable[[Path], None]]) -> None:
        """Write the files into the folder as one set, all or none.

        ``files`` maps a name of ``outputs`` to its bytes or to a function
        writing that file at a given path (a plot). All are written into a
        temporary sibling folder, which then replaces the folder in one step
        (:func:`swap_folder`); files of other names in the folder are kept
        (moved back from the old folder).

        Raises
        ------
        ValueError
            A name that is not one of ``outputs``, or outside the ``with`` block.
        OSError
            If a file cannot be written or the folders cannot be swapped; the
            folder then holds its old files.
        """
        if self._fd is None:
            raise ValueError("LockedFolder.write_set outside its with block")
        unknown = sorted(set(files) - set(self._outputs))
        if unknown:
            raise ValueError(f"not among the folder's outputs {self._outputs}: {unknown}")
        staging = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.{self._tag}-", suffix=".tmp",
                                        dir=self.path.parent))
        try:
            mode = file_mode()
            for name, content in files.items():
                target = staging / name
                if callable(content):
                    content(target)
                else:
                    target.write_bytes(content)
                os.chmod(target, mode)
                fsync_path(target)
            os.chmod(staging, stat.S_IMODE(os.stat(self.path).st_mode))
            fsync_path(staging)
            swap_folder(staging, self.path)  # staging now holds the old set
        finally:
            self._settle(staging)
