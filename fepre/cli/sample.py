"""``fepre sample``: sample a model file on a grid: a .vti image, or a chunked zarr store for grids beyond memory."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import common


HELP = "sample a model file on a grid: a .vti image, or a chunked zarr store for grids beyond memory"


def configure(parser: argparse.ArgumentParser) -> None:
    common.model_argument(parser)
    parser.add_argument("-o", "--output", required=True,
                        help="grid file: .vti (held in memory), or .zarr (chunked, with --chunks)")
    parser.add_argument("--spacing", type=float, help="grid spacing (default: largest extent / 100)")
    parser.add_argument("--bounds", type=float, nargs=6, metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"),
                        help="box to sample (default: the model file's bounds, else the model's own)")
    parser.add_argument("--chunks", type=int, nargs="+", metavar="N",
                        help="nodes per chunk (one N, or three for x y z): sample chunk by chunk on dask into a zarr store")
    parser.add_argument("--band", type=float,
                        help="narrow band half-width: only nodes that may lie this close to the surface are evaluated")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing .zarr store")
    parser.add_argument("--quiet", action="store_true", help="print only the written file's name and errors")


def run(args: argparse.Namespace) -> int:
    from ..sampling import sample

    chunks = common.chunks_argument(args.chunks)
    if Path(args.output).suffix.lower() == ".zarr":
        output = Path(args.output)  # a store is a folder: checked below
    else:
        output = common.output_path(args.output, "--output", (".vti", ".zarr"))
    if output.suffix.lower() == ".zarr" and chunks is None:
        raise ValueError("--output .zarr needs --chunks (nodes per chunk, e.g. --chunks 128)")
    if output.suffix.lower() == ".vti" and chunks is not None:
        raise ValueError("--chunks writes a .zarr store; give --output NAME.zarr (a .vti is held in memory)")
    if args.spacing is not None and not args.spacing > 0:
        raise ValueError(f"--spacing must be > 0; got {args.spacing:g}")
    if chunks is not None:
        from ..chunked.sampling import check_store

        try:
            check_store(output, args.overwrite)
        except FileExistsError:
            raise ValueError(f"--output {str(output)!r} already exists; pass --overwrite to replace it") from None
        except FileNotFoundError:
            raise ValueError(f"--output {str(output)!r}: the folder {str(output.parent)!r} does not exist") from None
    part = common.load_part(args)
    bounds = part.bounds if args.bounds is None else common.bounds_argument(args.bounds)
    spacing = args.spacing
    if spacing is None:
        spacing = max(b - a for a, b in zip(*bounds)) / 100.0 if bounds is not None else common.default_spacing(part)
    say = (lambda message: None) if args.quiet else common.say
    say(f"fepre sample: spacing {spacing:g} ...")
    if chunks is None:
        grid = sample(part.model, spacing=spacing, bounds=bounds, band=args.band)
        common.write_atomically(lambda path: grid.save(str(path)), output)
    else:
        import contextlib

        from ..chunked.cluster import distributed_client

        bar = contextlib.nullcontext()
        if not args.quiet and distributed_client() is None:
            from dask.diagnostics import ProgressBar

            bar = ProgressBar(out=sys.stderr)
        with bar:
            grid = sample(part.model, spacing=spacing, bounds=bounds, band=args.band, chunks=chunks,
                          store=output, overwrite=args.overwrite)
        say(f"fepre sample: {grid}")
    print(f"wrote {output}")
    return 0
