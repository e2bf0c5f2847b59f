"""The ``viscore`` command line: parse, call one public function, format.

Exit codes, the same for every subcommand:
"""

from __future__ import annotations

import argparse
import logging
import sys
import traceback

import viscore
from viscore import InputError, set_workers
from viscore._validate import as_seed

from . import (
    compare_cmd,
    cull_cmd,
    data_cmd,
    generate_cmd,
    metrics_cmd,
    occlude_cmd,
    uncertainty_cmd,
)
from .bench import command as bench_cmd

#: Subcommand modules; each has ``add_parser(subparsers, common)`` and sets ``run``.
_COMMANDS = [compare_cmd, generate_cmd, metrics_cmd, uncertainty_cmd, data_cmd, cull_cmd,
             occlude_cmd, bench_cmd]

#: Exit codes (see the module docstring and the README).
EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 130

#: Longest error line printed (long library messages are cut).
_MAX_LINE = 400


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # usage errors: one line, exit 2
        print(f"viscore: error: {_one_line(message)} (see '{self.prog} --help')",
              file=sys.stderr)
        raise SystemExit(EXIT_BAD_INPUT)


class _StderrHandler(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is at the time of each record."""

    def __init__(self) -> None:
        super().__init__()
        self.setFormatter(logging.Formatter("viscore: %(message)s"))

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value) -> None:  # StreamHandler.__init__ assigns it; ignore
        pass


def _one_line(text: object) -> str:
    line = " ".join(str(text).split())
    return line if len(line) <= _MAX_LINE else line[: _MAX_LINE - 3] + "..."


def _seed(text: str) -> int:
    """argparse type of ``--seed``: the one seed rule (:func:`viscore._validate.as_seed`)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a non-negative integer, got {text!r}") from None
    try:
        return as_seed(value, "--seed")
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--seed: ")) from None


def common_options() -> argparse.ArgumentParser:
    """Options every subcommand takes: ``--json``, ``--seed``, ``--quiet``, ``--debug``."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--json", action="store_true",
                   help="print one JSON document on stdout and nothing else there")
    p.add_argument("--seed", type=_seed, default=0,
                   help="seed of every random choice, a non-negative integer (default 0)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress or log lines on stderr (errors only)")
    # also accepted after the subcommand; SUPPRESS keeps a `viscore --debug ...` given before
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="print the traceback of an internal error")
    return p


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="viscore",
        description="Monte-Carlo visibility toolkit: generate occluders, measure them, "
                    "compare methods.",
        epilog="exit codes: 0 success, 1 a check failed (validate), 2 bad input, "
               "3 internal error (rerun with --debug for the traceback), 130 interrupted")
    parser.add_argument("--workers", type=int, default=None,
                        help="ray-casting threads (default: one per core)")
    parser.add_argument("--verbose", action="store_true", help="log details on stderr")
    parser.add_argument("--debug", action="store_true",
                        help="print the traceback of an internal error (exit code 3)")
    parser.add_argument("--version", action="version", version=f"viscore {viscore.__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    common = common_options()
    for module in _COMMANDS:
        module.add_parser(sub, common)
    return parser


def configure_logging(*, verbose: bool = False, quiet: bool = False) -> None:
    """Route log records to stderr, one line each, at the level the flags ask for.

    ``viscore`` loggers: DEBUG with ``--verbose``, ERROR with ``--quiet``
    (no INFO or WARNING lines), INFO otherwise. Other libraries: WARNING, or
    ERROR with ``--quiet``. Python warnings go through logging too, so
    ``--quiet`` silences them. Safe to call once per command in one process.
    """
    root = logging.getLogger()
    for handler in [h for h in root.handlers if isinstance(h, _StderrHandler)]:
        root.removeHandler(handler)
    root.addHandler(_StderrHandler())
    root.setLevel(logging.ERROR if quiet else logging.WARNING)
    logging.getLogger("viscore").setLevel(
        logging.DEBUG if verbose else logging.ERROR if quiet else logging.INFO)
    logging.captureWarnings(quiet)


def main(argv: list[str] | None = None) -> int:
    """Run one ``viscore`` command; returns the exit code (see the module docstring)."""
    words = sys.argv[1:] if argv is None else [str(a) for a in argv]
    # building the parser reads the registry, which discovers plugins: their warning
    # lines must already go through our handler (and --quiet must silence them)
    configure_logging(verbose="--verbose" in words, quiet="--quiet" in words)
    try:  # (plugins are imported here: a Ctrl-C then is an interruption like any other)
        parser = build_parser()
    except KeyboardInterrupt:
        print("viscore: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # noqa: BLE001 - the parser itself failed: a bug of ours
        if "--debug" in words:
            traceback.print_exc()
        print(f"viscore: internal error: {_one_line(f'{type(exc).__name__}: {exc}')} (this is "
              "a bug; run 'viscore --debug ...' for the traceback)", file=sys.stderr)
        return EXIT_INTERNAL
    try:
        args, extras = parser.parse_known_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error already printed
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    if extras:
        where = " ".join(x for x in ("viscore", args.command, getattr(args, "method", None)) if x)
        print(f"viscore: error: unrecognized arguments: {_one_line(' '.join(extras))} "
              f"(see '{where} --help')", file=sys.stderr)
        return EXIT_BAD_INPUT
    debug = bool(getattr(args, "debug", False))
    configure_logging(verbose=args.verbose, quiet=getattr(args, "quiet", False))
    try:
        set_workers(args.workers)
        return int(args.run(args) or 0)
    except InputError as exc:
        if debug:
            traceback.print_exc()
        print(f"viscore: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # unwritable output, full disk, unreadable input
        if debug:
            traceback.print_exc()
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        print(f"viscore: error: {_one_line(exc.strerror or exc)}{where}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("viscore: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # noqa: BLE001 - the one place internal errors are reported
        if debug:
            traceback.print_exc()
        detail = _one_line(f"{type(exc).__name__}: {exc}")
        print(f"viscore: internal error: {detail} (this is a bug; run 'viscore --debug "
              f"{args.command} ...' for the traceback)" if not debug else
              f"viscore: internal error: {detail}", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
