"""One error rule for every subcommand (implemented once, in ``viscore.cli.main``).

Bad input: exit 2 and one line naming the option or file. Internal error: exit 3
and one line saying so and how to see the traceback (``--debug``). Ctrl-C: exit
130 and one line. ``--quiet`` leaves exactly the one error line.
"""

import logging

import pytest

from viscore import InputError
from viscore.cli import metrics_cmd
from viscore.cli.main import main
from viscore.generators import REGISTRY, GeneratorSpec


def _raising(exc):
    def generator(mesh, *, budget=None, seed=0):
        raise exc
    return generator


@pytest.fixture
def broken(monkeypatch):
    """Registers a generator ``broken`` that raises the exception given to the returned setter."""
    def install(exc):
        monkeypatch.setitem(REGISTRY, "broken",
                            GeneratorSpec("broken", _raising(exc), "always fails"))
    return install


def test_internal_error_exit_3_one_line(broken, tmp_path, capsys):
    broken(TypeError("unsupported operand type(s) for +: 'int' and 'str'"))
    out = tmp_path / "o.ply"
    assert main(["generate", "broken", "cow", "-o", str(out)]) == 3
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("viscore: internal error: TypeError: unsupported operand")
    assert "--debug" in err[0] and "Traceback" not in captured.err
    assert not out.exists() and captured.out == ""


@pytest.mark.parametrize("where", ["before", "after"])
def test_internal_error_debug_prints_traceback(broken, tmp_path, capsys, where):
    broken(TypeError("a real bug"))
    argv = ["generate", "broken", "cow", "-o", str(tmp_path / "o.ply")]
    argv = ["--debug", *argv] if where == "before" else [*argv, "--debug"]
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "TypeError: a real bug" in err
    assert "in generator" in err  # the frame that raised
    assert err.strip().splitlines()[-1].startswith("viscore: internal error: TypeError")


def test_internal_error_multiline_message_is_one_line(broken, tmp_path, capsys):
    broken(RuntimeError("QH6154 qhull precision error\nline two\n\n  line three"))
    assert main(["generate", "broken", "cow", "-o", str(tmp_path / "o.ply")]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "line two line three" in err[0]


def test_input_error_from_a_generator_exit_2(broken, tmp_path, capsys):
    broken(InputError("voxels: at most 1000 allowed, got 5000"))
    assert main(["generate", "broken", "cow", "-o", str(tmp_path / "o.ply")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["viscore: error: voxels: at most 1000 allowed, got 5000"]


def test_keyboard_interrupt_exit_130(broken, tmp_path, capsys):
    broken(KeyboardInterrupt())
    assert main(["generate", "broken", "cow", "-o", str(tmp_path / "o.ply")]) == 130
    assert capsys.readouterr().err.strip().splitlines() == ["viscore: interrupted"]


def test_internal_error_rule_holds_for_other_subcommands(monkeypatch, capsys):
    def boom(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(metrics_cmd, "load_mesh", boom)
    assert main(["measure", "cow", "--quiet"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("viscore: internal error: ZeroDivisionError")


def test_os_error_on_output_path_exit_2_names_it(tmp_path, capsys):
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a folder")
    out = blocker / "o.ply"
    assert main(["generate", "bbox", "cow", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("viscore: error:") and "file.txt" in err[0]


def test_usage_errors_return_2_with_one_line(capsys):
    for argv in (["generate"], ["generate", "nope", "cow", "-o", "x.ply"], ["nope"],
                 ["generate", "bbox", "cow"], ["measure", "cow", "--seed", "x"],
                 ["generate", "qem", "cow", "-o", "x.ply", "--max-boxes", "3"]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("viscore: error:"), (argv, err)


def test_quiet_failing_command_prints_exactly_one_line(monkeypatch, tmp_path, capsys):
    def chatty(mesh, *, budget=None, seed=0):
        logging.getLogger("viscore.generators.chatty").info("dropped 3 degenerate face(s)")
        logging.getLogger("viscore.generators.chatty").warning("not watertight")
        logging.getLogger("somelib").warning("a library's own warning")
        raise InputError("cow: something is wrong")

    monkeypatch.setitem(REGISTRY, "chatty", GeneratorSpec("chatty", chatty, "logs, then fails"))
    out = str(tmp_path / "o.ply")
    assert main(["generate", "chatty", "cow", "-o", out]) == 2
    loud = capsys.readouterr().err.strip().splitlines()
    assert len(loud) == 4 and "degenerate" in loud[0]  # the log lines are there without --quiet
    assert main(["generate", "chatty", "cow", "-o", out, "--quiet"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "viscore: error: cow: something is wrong"]


def test_quiet_silences_warnings(tmp_path, capsys):
    out = str(tmp_path / "b.ply")
    assert main(["generate", "bbox", "cow", "-o", out, "--budget", "5", "--quiet"]) == 0
    assert capsys.readouterr().err == ""
