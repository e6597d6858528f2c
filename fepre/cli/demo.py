"""``fepre demo``: mesh the demo parts; write STL, VTU, INP and one HTML report."""

from __future__ import annotations

import argparse

from . import common


HELP = "mesh the demo parts; write STL, VTU, INP and one HTML report"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("outdir", nargs="?", default="fepre-demo", help="output folder (default ./fepre-demo)")
    parser.add_argument("--quick", action="store_true", help="coarse settings (seconds, for tests)")
    parser.add_argument("--no-references", action="store_true", help="skip the pytetwild/gmsh reference meshes")


def run(args: argparse.Namespace) -> int:
    from ..demo import run_demo

    result = run_demo(args.outdir, quick=args.quick, references=not args.no_references, progress=common.say)
    return 1 if result.failures else 0
