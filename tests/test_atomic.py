"""viscore/_atomic.py: a set of files beside others, written all or none (:class:`FileSet`),
and an output folder held by one process, its files swapped in as a set
(:class:`LockedFolder`)."""

import errno
import os
import stat

import pytest

from viscore import InputError, _atomic
from viscore._atomic import FileSet, LockedFolder, file_mode


def _contents(folder) -> dict:
    """Every entry of ``folder``, hidden ones too, as name -> bytes (a folder: None)."""
    return {p.name: None if p.is_dir() else p.read_bytes() for p in sorted(folder.iterdir())}


def test_a_file_set_lands_whole_with_the_modes_open_gives(tmp_path):
    (tmp_path / "mine.txt").write_bytes(b"the user's")
    (tmp_path / "b.ply").write_bytes(b"old b")
    os.chmod(tmp_path / "b.ply", 0o640)
    with FileSet(tmp_path) as files:
        assert files.write("a.ply", b"new a") == tmp_path / "a.ply"
        files.write("b.ply", b"new b")
        staged = {k: v for k, v in _contents(tmp_path).items() if v is not None}
        assert staged == {"b.ply": b"old b", "mine.txt": b"the user's"}  # nothing in place yet
        assert [p.name for p in tmp_path.glob(".viscore-set-*.tmp")] != []
    assert _contents(tmp_path) == {"a.ply": b"new a", "b.ply": b"new b",
                                   "mine.txt": b"the user's"}
    assert stat.S_IMODE(os.stat(tmp_path / "a.ply").st_mode) == file_mode()
    assert stat.S_IMODE(os.stat(tmp_path / "b.ply").st_mode) == 0o640  # kept


def test_a_failure_in_the_block_leaves_none_of_the_set(tmp_path):
    (tmp_path / "b.ply").write_bytes(b"old b")
    with pytest.raises(OSError, match="No space"):
        with FileSet(tmp_path) as files:
            for i in range(4):
                files.write(f"n{i}.ply", b"x")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # the 5th file
    assert _contents(tmp_path) == {"b.ply": b"old b"}  # no part, no temporary folder


def test_a_failed_write_names_the_final_path(tmp_path, monkeypatch):
    real = os.fsync
    calls = []

    def fsync(fd):
        calls.append(fd)
        if len(calls) == 3:
            raise OSError(errno.EIO, "Input/output error")
        return real(fd)

    monkeypatch.setattr(_atomic.os, "fsync", fsync)
    with pytest.raises(OSError) as caught:
        with FileSet(tmp_path) as files:
            for i in range(5):
                files.write(f"n{i}.ply", b"x")
    assert caught.value.filename == str(tmp_path / "n2.ply")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_move_undoes_the_moves_made(tmp_path, monkeypatch):
    for name in ("a", "c"):
        (tmp_path / name).write_bytes(b"old " + name.encode())
    real = os.replace
    moves = []

    def replace(src, dst):
        moves.append(dst)
        if len(moves) == 3:  # the third file's move fails
            raise OSError(errno.EIO, "Input/output error")
        return real(src, dst)

    monkeypatch.setattr(_atomic.os, "replace", replace)
    with pytest.raises(OSError) as caught:
        with FileSet(tmp_path) as files:
            for name in ("a", "b", "c", "d"):
                files.write(name, b"new " + name.encode())
    assert caught.value.filename == str(tmp_path / "c")
    # a replaced file is back, a new one removed: the folder as before
    assert _contents(tmp_path) == {"a": b"old a", "c": b"old c"}


@pytest.mark.parametrize("name", ["", ".", "..", "sub/x.ply", "../x.ply"])
def test_a_file_set_takes_plain_names_only(tmp_path, name):
    with pytest.raises(ValueError, match="without a folder"):
        with FileSet(tmp_path) as files:
            files.write(name, b"x")
    assert list(tmp_path.iterdir()) == []


def test_a_name_is_written_once(tmp_path):
    with pytest.raises(ValueError):
        with FileSet(tmp_path) as files:
            files.write("a", b"1")
            files.write("a", b"2")
    assert list(tmp_path.iterdir()) == []


def test_a_missing_folder_names_it(tmp_path):
    with pytest.raises(OSError) as caught:
        with FileSet(tmp_path / "missing"):
            pass
    assert caught.value.filename == str(tmp_path / "missing")


# ----------------------------------------------------------------------------- LockedFolder

SET = ("doc.json", "plot.png")


def _held(path, **kwargs) -> LockedFolder:
    return LockedFolder(path, busy=f"{path}: busy", outputs=SET, tag="t", **kwargs)


def test_locked_folder_swaps_a_set_in_and_keeps_the_users_files(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "doc.json").write_bytes(b"old")
    (out / "notes.txt").write_bytes(b"mine")
    with _held(out) as folder:
        folder.write_set({"doc.json": b"new", "plot.png": lambda p: p.write_bytes(b"png")})
    assert _contents(out) == {"doc.json": b"new", "notes.txt": b"mine", "plot.png": b"png"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging left
    assert stat.S_IMODE(os.stat(out / "plot.png").st_mode) == file_mode()


def test_locked_folder_refuses_a_second_holder_and_leaves_its_folder(tmp_path):
    out = tmp_path / "out"
    with _held(out):
        with pytest.raises(InputError, match="out: busy"):
            with _held(out):
                pass
        assert out.is_dir()  # the first holder's folder stays
    with _held(out):  # released
        pass


@pytest.mark.parametrize("existed", [False, True])
def test_locked_folder_a_failed_block_removes_only_an_empty_folder_it_made(tmp_path, existed):
    out = tmp_path / "out"
    if existed:
        out.mkdir()
    with pytest.raises(KeyboardInterrupt):
        with _held(out):
            raise KeyboardInterrupt
    assert out.is_dir() == existed
    with pytest.raises(OSError):
        with _held(out):
            (out / "partial.bin").write_bytes(b"x")
            raise OSError("disk full")
    assert (out / "partial.bin").is_file()  # never a file of a run


def test_locked_folder_settles_what_a_killed_run_left(tmp_path):
    """A set staged beside the folder (the run killed before or after the swap) and a
    half-written copy inside: our files go, the user's file comes back."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "doc.json").write_bytes(b"kept")
    (out / ".doc.k1l2.json").write_bytes(b"{")  # half-written
    old = tmp_path / ".out.old-x.tmp"  # an old set swapped aside, the user's file with it
    old.mkdir()
    (old / "plot.png").write_bytes(b"old png")
    (old / "notes.txt").write_bytes(b"mine")
    new = tmp_path / ".out.t-y.tmp"  # a new set never swapped in
    new.mkdir()
    (new / "doc.json").write_bytes(b"new, unplaced")
    with _held(out):
        pass
    assert _contents(out) == {"doc.json": b"kept", "notes.txt": b"mine"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_locked_folder_failed_swap_keeps_the_old_set(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / "doc.json").write_bytes(b"old")

    def refused(new, target):
        raise OSError(errno.EXDEV, os.strerror(errno.EXDEV), str(target))

    monkeypatch.setattr(_atomic, "swap_folder", refused)
    with pytest.raises(OSError, match="out"):
        with _held(out) as folder:
            folder.write_set({"doc.json": b"new", "plot.png": b"png"})
    assert _contents(out) == {"doc.json": b"old"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_locked_folder_with_a_lock_file_locks_that_file(tmp_path):
    import fcntl

    out = tmp_path / "study"
    with LockedFolder(out, busy="busy", lock_file=".lock"):
        assert (out / ".lock").is_file()
        fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # the folder itself is free
        finally:
            os.close(fd)
        with pytest.raises(InputError, match="busy"):
            with LockedFolder(out, busy="busy", lock_file=".lock"):
                pass


def test_locked_folder_write_set_takes_the_declared_names_inside_its_block(tmp_path):
    folder = _held(tmp_path / "out")
    with pytest.raises(ValueError, match="outside"):
        folder.write_set({"doc.json": b"x"})
    with folder:
        with pytest.raises(ValueError, match="other.txt"):
            folder.write_set({"other.txt": b"x"})
    assert _contents(tmp_path / "out") == {}
