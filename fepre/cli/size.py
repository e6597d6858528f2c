"""``fepre size``: the automatic size field of a model file: write it as an image (.vti) to look at or edit."""

from __future__ import annotations

import argparse

import numpy as np

from . import common


HELP = "the automatic size field of a model file: write it as an image (.vti) to look at or edit"


def configure(parser: argparse.ArgumentParser) -> None:
    common.model_argument(parser)
    parser.add_argument("-o", "--output", required=True, help="write the size field here (.vti)")
    parser.add_argument("--h", type=common.length, help="smallest edge length, the field's floor (default: the model file's h)" + common.LENGTH_HELP)
    parser.add_argument("--hmax", type=common.length, required=True, help="largest edge length (--h is the smallest: the field never goes below it; walls, gaps "
                        "and edges that would need smaller are named in a warning)")
    parser.add_argument("--elements-across", type=float, default=3.0, help="elements through every wall (default 3)")
    parser.add_argument("--chord-tolerance", type=float, help="largest chord error on curved faces (default: the smaller of h/10 and 0.003 times the radius)")
    parser.add_argument("--gradation", type=float, default=1.3, help="largest ratio of neighbouring sizes (default 1.3)")
    parser.add_argument("--no-features", action="store_true", help="do not refine where sharp edges face each other closely")


def run(args: argparse.Namespace) -> int:
    from ..sizing import size_field
    from ..sizing.estimate import estimated_cells

    output = common.output_path(args.output, "--output", (".vti",))
    common.require_edge_length(args)
    part = common.load_part(args)
    lower, upper = (np.asarray(v, dtype=np.float64) for v in part.domain_bounds())
    h = common.edge_length(args, part)
    if not args.hmax > h:
        raise ValueError(f"--hmax must be larger than --h; got --hmax {args.hmax:g} and --h {h:g}")
    common.say(f"fepre size: sizes from {h:g} to {args.hmax:g} ...")
    field = size_field(part.model, h, args.hmax, elements_across=args.elements_across,
                       chord_tolerance=args.chord_tolerance, gradation=args.gradation,
                       features=not args.no_features, bounds=part.bounds)
    graded = estimated_cells(part.model, field, field.hmin, lower, upper, True)
    uniform = estimated_cells(part.model, None, h, lower, upper, False)
    print(f"size field: {field.shape[0]} x {field.shape[1]} x {field.shape[2]} nodes at spacing {float(field.spacing[0]):.4g}, "
          f"sizes {field.hmin:.4g} to {field.hmax:.4g}, built in {field.seconds:.1f} s")
    print(f"estimated cells: {graded:,.0f} graded, {uniform:,.0f} uniform at h={h:g} ({graded / max(uniform, 1):.1%})")
    image = field.to_image()
    common.write_atomically(lambda path: image.save(str(path)), output)
    print(f"wrote {output}")
    return 0
