"""The ``fepre`` command.

Each subcommand is a module of this package with ``HELP`` (its one-line help), ``configure(parser)``
(its argparse sub-parser) and ``run(args) -> exit code``; :data:`COMMANDS` lists them in the order
``fepre --help`` shows. Errors meant for users are printed without a traceback (exit code 1; bad
usage 2).
"""

from __future__ import annotations

import argparse
import sys
from types import ModuleType

from .. import __version__
from ..errors import MeshingError
from . import bench, common, compare, demo, features, homogenize, info, mesh, sample, size, surface, view

__all__ = ["COMMANDS", "build_parser", "main"]

COMMANDS: dict[str, ModuleType] = {
    module.__name__.rsplit(".", 1)[1]: module
    for module in (bench, surface, sample, mesh, size, features, compare, view, info, homogenize, demo)
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fepre",
        description="Finite-element pre-processing for signed distance function models.",
    )
    parser.add_argument("--version", action="version", version=f"fepre {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module in COMMANDS.items():
        subparser = subparsers.add_parser(name, help=module.HELP, description=module.HELP)
        module.configure(subparser)
        subparser.set_defaults(command_parser=subparser)  # for errors in its options: its own usage
    return parser


def _blamed(parser: argparse.ArgumentParser, args: argparse.Namespace, unknown: list[str],
            argv: list[str]) -> argparse.ArgumentParser:
    """The parser whose usage fits unknown arguments: the command's, unless one comes before it."""
    if args.command is None:
        return parser
    position = argv.index(args.command) if args.command in argv else len(argv)
    return parser if any(word in argv[:position] for word in unknown) else args.command_parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fepre`` console script."""
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # argparse would blame the top-level parser, whose usage says nothing of the options
        _blamed(parser, args, unknown, sys.argv[1:] if argv is None else list(argv)).error(
            f"unrecognized arguments: {' '.join(unknown)}")
    if args.command is None:
        parser.print_help()
        return 2
    run = COMMANDS[args.command].run
    import warnings

    common.start_log()

    def one_line(message, category, filename, lineno, file=None, line=None) -> None:
        # a warning is news for the user, not a pointer into fepre's source
        text = str(message).strip().replace("\n", " ")
        print(f"fepre {args.command}: warning: {text}", file=sys.stderr, flush=True)

    shown = warnings.showwarning
    warnings.showwarning = one_line
    try:
        return int(run(args) or 0)
    except (ValueError, TypeError, OSError, MeshingError) as exc:
        notes = " ".join(str(note) for note in getattr(exc, "__notes__", ()))  # the frame a place is in, the likely cause
        print(f"fepre {args.command}: error: {exc}" + (f" ({notes})" if notes else ""), file=sys.stderr)
        return 1
    except ImportError as exc:  # an optional dependency the command needs is not installed
        print(f"fepre {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # pragma: no cover
        print("interrupted", file=sys.stderr)
        return 130
    finally:
        warnings.showwarning = shown


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
