"""``fepre homogenize``: mesh one periodic cell and compute its effective elastic stiffness in CalculiX."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from . import common


HELP = "mesh one periodic cell and compute its effective elastic stiffness in CalculiX"


def configure(parser: argparse.ArgumentParser) -> None:
    common.model_argument(parser)
    common.period_argument(parser, required=True)
    parser.add_argument("--h", type=common.length, help="target edge length (default: the model file's h)" + common.LENGTH_HELP)
    parser.add_argument("--E", type=float, required=True, help="Young's modulus of the solid")
    parser.add_argument("--nu", type=float, required=True, help="Poisson's ratio of the solid")
    parser.add_argument("--order", type=int, choices=(1, 2), default=2, help="C3D4 (1) or C3D10 (2, default)")
    parser.add_argument("-o", "--output", help="also write the cell's mesh (.vtu, .inp with its *EQUATION constraints, ...)")
    parser.add_argument("--workdir", help="an existing folder to keep CalculiX's files in")
    parser.add_argument("--json", help="write the result (stiffness, density, moduli) to this .json file")
    common.seed_argument(parser)
    parser.add_argument("--quiet", action="store_true", help="print only the result")


def run(args: argparse.Namespace) -> int:
    import json

    import fepre

    from ..homogenization import _ccx

    period = common.periods(args.period)
    if not (np.isfinite(args.E) and args.E > 0):
        raise ValueError(f"--E must be a positive Young's modulus; got {args.E:g}")
    if not -1.0 < args.nu < 0.5:
        raise ValueError(f"--nu must lie in (-1, 0.5) for an isotropic solid; got {args.nu:g}")
    _ccx(None)
    output = common.output_path(args.output, "--output", common.mesh_suffixes()) if args.output else None
    json_path = common.output_path(args.json, "--json", (".json",)) if args.json else None
    if args.workdir is not None and not Path(args.workdir).is_dir():
        raise ValueError(f"--workdir {args.workdir!r} is not an existing folder")
    part = common.load_part(args)
    common.check_period_bounds(period, part)
    h = common.edge_length(args, part)
    say = (lambda message: None) if args.quiet else common.say
    say(f"fepre homogenize: DistMesh of the periodic cell, h={h:g} ...")
    start = time.perf_counter()
    mesh = fepre.distmesh(part.model, h, bounds=part.bounds, periodic=period, progress=not args.quiet, seed=args.seed)
    say(f"fepre homogenize: {mesh.n_cells} tetrahedra in {time.perf_counter() - start:.1f} s; six load cases in CalculiX ...")
    if output is not None:
        fepre.export(mesh, output, order=args.order, model=part.model)
        from ..export.formats import resolve_format

        for path in (output, *common.companions(output, resolve_format(output, None))):
            say(f"fepre homogenize: wrote {path}")
    result = fepre.homogenize(mesh, {"E": args.E, "nu": args.nu}, order=args.order, model=part.model, workdir=args.workdir)
    print(result)
    print(f"  nu = {np.array2string(result.poisson_ratios[[0, 0, 1], [1, 2, 2]], precision=4)} (12, 13, 23)")
    if json_path is not None:
        record = {
            "stiffness_voigt_11_22_33_23_13_12": result.stiffness.tolist(),
            "relative_density": result.relative_density,
            "young_moduli": result.young_moduli.tolist(),
            "shear_moduli_23_13_12": result.shear_moduli.tolist(),
            "material": {"E": args.E, "nu": args.nu},
            "cells": result.cells, "order": result.order, "h": h, "period": list(np.broadcast_to(period, 3)),
        }
        common.write_atomically(lambda path: path.write_text(json.dumps(record, indent=2)), json_path)
        say(f"fepre homogenize: wrote {json_path}")
    return 0
