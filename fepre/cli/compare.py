"""``fepre compare``: mesh a model file with fepre and reference meshers and compare them."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import common


HELP = "mesh a model file with fepre and reference meshers and compare them"


def configure(parser: argparse.ArgumentParser) -> None:
    common.model_argument(parser)
    parser.add_argument("--h", type=common.length, help="target edge length (default: the model file's h)" + common.LENGTH_HELP)
    parser.add_argument("--report", help="write a self-contained HTML report here")
    parser.add_argument("--references", nargs="*", default=["pytetwild"], metavar="NAME",
                        help="reference meshers: pytetwild, gmsh (default: pytetwild)")
    parser.add_argument("--surface-spacing", type=float, help="spacing of the surface the references mesh (default h/4)")
    parser.add_argument("--exact-volume", type=float, help="the part's exact volume, if known")
    parser.add_argument("--json", help="write the figures as JSON here")
    common.seed_argument(parser)


def run(args: argparse.Namespace) -> int:
    from ..compare import compare

    common.output_path(args.report, "--report", (".html", ".htm"))
    common.output_path(args.json, "--json", (".json",))
    part = common.load_part(args)
    part.domain_bounds()  # an unbounded model without `bounds`: the model-file hint, before any work
    h = common.edge_length(args, part)
    result = compare(part.model, h, references=tuple(args.references), surface_spacing=args.surface_spacing,
                     exact_volume=args.exact_volume, bounds=part.bounds, seed=args.seed, progress=common.say)
    print(result.table())
    if args.json:
        import json

        text = json.dumps(result.to_dict(), indent=2, default=str)
        common.write_atomically(lambda path: path.write_text(text), Path(args.json))
        print(f"wrote {args.json}")
    if args.report:
        from ..report import write_report

        write_report({part.name: result}, args.report, progress=common.say)
        print(f"wrote {args.report}")
    return 0
