"""The ``viscore`` command line: parse, call one public function, format.

Exit codes: 0 success, 1 a check that ran and failed (``validate``), 2 bad
input or usage, with one line on stderr saying what and where.
"""

from __future__ import annotations

import argparse
import logging
import sys

from viscore import InputError, set_workers

from . import bench_cmd, compare_cmd, data_cmd, generate_cmd, metrics_cmd, uncertainty_cmd

#: Subcommand modules; each has ``add_parser(subparsers)`` and ``run(args) -> int``.
_COMMANDS = [compare_cmd, generate_cmd, metrics_cmd, uncertainty_cmd, data_cmd, bench_cmd]


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # usage errors: one line, exit 2
        print(f"viscore: error: {message} (see 'viscore --help')", file=sys.stderr)
        raise SystemExit(2)


def common_options() -> argparse.ArgumentParser:
    """Options every subcommand takes: ``--json``, ``--seed``, ``--quiet``."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--json", action="store_true",
                   help="print one JSON document on stdout and nothing else there")
    p.add_argument("--seed", type=int, default=0, help="seed of every random choice (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress or log lines on stderr")
    return p


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("viscore")
    except PackageNotFoundError:  # pragma: no cover - running from a bare checkout
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="viscore", description=(
        "Monte-Carlo visibility toolkit: generate occluders, measure them, compare methods."))
    parser.add_argument("--workers", type=int, default=None,
                        help="ray-casting threads (default: one per core)")
    parser.add_argument("--verbose", action="store_true", help="log details on stderr")
    parser.add_argument("--version", action="version", version=f"viscore {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    common = common_options()
    for module in _COMMANDS:
        module.add_parser(sub, common)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.DEBUG if args.verbose else (
        logging.WARNING if getattr(args, "quiet", False) else logging.INFO)
    logging.basicConfig(level=level, stream=sys.stderr, format="viscore: %(message)s")
    try:
        set_workers(args.workers)
        return int(args.run(args) or 0)
    except InputError as exc:
        print(f"viscore: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # unwritable output, full disk, unreadable input
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        print(f"viscore: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("viscore: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
