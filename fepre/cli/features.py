"""``fepre features``: find the sharp corners and edges of a model file; print and write them."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import common


HELP = "find the sharp corners and edges of a model file; print and write them"


def configure(parser: argparse.ArgumentParser) -> None:
    common.model_argument(parser)
    parser.add_argument("--h", type=float, help="node spacing along the curves (default: the model file's h)")
    parser.add_argument("--angle", type=float, default=30.0, help="crease threshold in degrees (default 30)")
    parser.add_argument("-o", "--output", help="write the corners and curves here (.vtp or .vtk)")


def run(args: argparse.Namespace) -> int:
    import fepre

    common.output_path(args.output, "--output", (".vtp", ".vtk"))
    part = common.load_part(args)
    part.domain_bounds()  # an unbounded model without `bounds`: the model-file hint, before any work
    h = common.edge_length(args, part)
    found = fepre.features(part.model, h, angle=args.angle, bounds=part.bounds, warn=False)
    print(found)
    if args.output:
        mesh = found.to_polydata()
        common.write_atomically(lambda path: mesh.save(str(path)), Path(args.output))
        print(f"wrote {args.output}")
    return 0
