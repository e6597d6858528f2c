"""``fepre bench``: run a benchmark against peers and print its figures."""

from __future__ import annotations

import argparse


HELP = "run a benchmark against peers and print its figures"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", nargs="?", help="benchmark to run (omit, or --list, to list them)")
    parser.add_argument("--list", action="store_true", help="list the benchmarks")
    parser.add_argument("args", nargs=argparse.REMAINDER, help="arguments passed to the benchmark")


def run(args: argparse.Namespace) -> int:
    from .. import bench

    if args.list or not args.name:
        for name, description in sorted(bench.available().items()):
            print(f"{name:12s} {description}")
        return 0
    return bench.run(args.name, args.args)
