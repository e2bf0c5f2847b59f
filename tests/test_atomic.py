"""viscore/_atomic.py: a set of files beside others, written all or none (:class:`FileSet`)."""

import errno
import os
import stat

import pytest

from viscore import _atomic
from viscore._atomic import FileSet, file_mode


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
