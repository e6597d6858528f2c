"""The ``fepre`` command.

Subcommands are small functions registered in ``COMMANDS``; each gets its own argparse
sub-parser. Errors meant for users are printed without a traceback (exit code 1; bad usage 2).
"""

from __future__ import annotations

import argparse
import sys
from typing import Callable

from . import __version__

Command = tuple[Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]
COMMANDS: dict[str, tuple[str, Command]] = {}


def command(name: str, help: str):
    """Register ``(configure, run)`` functions as subcommand ``name``."""

    def decorate(configure: Callable[[argparse.ArgumentParser], None]):
        def attach(run: Callable[[argparse.Namespace], int]):
            COMMANDS[name] = (help, (configure, run))
            return run

        return attach

    return decorate


def _configure_bench(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", nargs="?", help="benchmark to run (omit, or --list, to list them)")
    parser.add_argument("--list", action="store_true", help="list the benchmarks")
    parser.add_argument("args", nargs=argparse.REMAINDER, help="arguments passed to the benchmark")


@command("bench", "run a benchmark against peers and print its figures")(_configure_bench)
def _run_bench(args: argparse.Namespace) -> int:
    from . import bench

    if args.list or not args.name:
        for name, description in sorted(bench.available().items()):
            print(f"{name:12s} {description}")
        return 0
    return bench.run(args.name, args.args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fepre",
        description="Finite-element pre-processing for signed distance function models.",
    )
    parser.add_argument("--version", action="version", version=f"fepre {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (help_text, (configure, _)) in COMMANDS.items():
        configure(subparsers.add_parser(name, help=help_text, description=help_text))
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fepre`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    _, (_, run) = COMMANDS[args.command]
    try:
        return int(run(args) or 0)
    except (ValueError, TypeError, FileNotFoundError, PermissionError) as exc:
        print(f"fepre {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # pragma: no cover
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
