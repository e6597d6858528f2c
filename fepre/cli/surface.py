"""``fepre surface``: extract the surface of a model file and write it (STL, PLY, OBJ, VTP)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from . import common


SURFACE_SUFFIXES = (".stl", ".ply", ".obj", ".vtp", ".vtk")


HELP = "extract the surface of a model file and write it (STL, PLY, OBJ, VTP)"


def configure(parser: argparse.ArgumentParser) -> None:
    common.model_argument(parser)
    parser.add_argument("-o", "--output", required=True, help="surface file: .stl, .ply, .obj or .vtp")
    parser.add_argument("--method", default="flying_edges",
                        choices=("flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets",
                                 "dual_contouring"),
                        help="extraction method (dual_contouring keeps sharp edges and corners)")
    parser.add_argument("--spacing", type=float, help="grid spacing (default: largest extent / 100)")
    parser.add_argument("--level", type=float,
                        help="the level set to extract (default 0: the part's surface; > 0 an offset outward); "
                             "for an image MODEL the grey value of the part's boundary")
    common.image_arguments(parser, level=False)
    parser.add_argument("--bounds", type=float, nargs=6, metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"),
                        help="box to sample (default: the model file's bounds, else the model's own)")
    parser.add_argument("--chunks", type=int, nargs="+", metavar="N",
                        help="extract chunk by chunk on dask, N nodes per chunk (one N, or three for x y z); "
                             "with an .stl or .ply output the surface is streamed to the file, never held whole. "
                             "MODEL may then also be a zarr grid written by `fepre sample`")
    parser.add_argument("--band", type=float,
                        help="with --chunks: narrow band half-width (default two cells beyond the level); "
                             "chunks farther from the surface are skipped")
    parser.add_argument("--no-check", action="store_true", help="skip the surface check (watertight, genus, errors)")
    parser.add_argument("--quiet", action="store_true", help="print only the written file's name and errors")


def _run_chunked_surface(args: argparse.Namespace, output: Path, chunks, say) -> int:
    """``fepre surface --chunks``: from a model file or a zarr grid; .stl and .ply outputs are streamed."""
    from ..chunked import open_grid, write_isosurface
    from ..chunked.api import isosurface_chunked

    if common.is_zarr_grid(args.model):
        if args.spacing is not None or args.bounds is not None or args.band is not None:
            raise ValueError("--spacing, --bounds and --band apply to a model file; the zarr grid is already sampled")
        source = open_grid(args.model)
        chunks = source.chunks if chunks is None else chunks
        spacing_text = f"{float(source.spacing[0]):g}"
        options = {}
        model = None
    else:
        part = common.load_part(args)
        bounds = part.bounds if args.bounds is None else common.bounds_argument(args.bounds)
        spacing = args.spacing
        if spacing is None:
            spacing = max(b - a for a, b in zip(*bounds)) / 100.0 if args.bounds is not None or part.bounds is not None else common.default_spacing(part)
        source, model = part.model, part.model
        options = {"spacing": spacing, "bounds": bounds, "band": args.band}
        spacing_text = f"{spacing:g}"
    say(f"fepre surface: {args.method} at spacing {spacing_text}, chunks of {chunks} nodes ...")
    start = time.perf_counter()
    if output.suffix.lower() in (".stl", ".ply"):
        written = write_isosurface(
            source, output, method=args.method, level=common.surface_level(args, model), chunks=chunks, log=say, **options
        )
        say(f"fepre surface: {written.n_triangles:,} triangles from {written.chunks} chunks in {written.seconds:.1f} s")
        if not args.quiet:
            state = "closed and manifold" if written.closed else (
                f"NOT closed: {written.open_edges} open and {written.nonmanifold_edges} non-manifold edges")
            print(f"streamed surface: {written.n_triangles} triangles, {written.seam_edges} edges on chunk seams, {state}")
        print(f"wrote {output}")
        return 0
    surface = isosurface_chunked(
        source, method=args.method, level=common.surface_level(args, model), chunks=chunks, spacing=options.get("spacing"),
        shape=None, bounds=options.get("bounds"), band=options.get("band"), model=None, normals=False,
        progress=not args.quiet,
    )
    say(f"fepre surface: {surface.n_cells} triangles in {time.perf_counter() - start:.2f} s")
    if surface.n_cells == 0:
        raise ValueError(f"the surface of {args.model} is empty at spacing {spacing_text}; nothing written")
    if not args.no_check:
        _check_surface_file(surface, model, float(spacing_text), args.quiet)
    common.write_atomically(lambda path: surface.save(str(path)), output)
    print(f"wrote {output}")
    return 0


def _check_surface_file(surface, model, spacing: float, quiet: bool) -> None:
    """Print the surface check; warn about components below the grid's resolution."""
    from ..surface import check_surface

    check = check_surface(surface, model)
    if not quiet:
        print(check)
    if check.thin_components:
        import warnings

        from ..errors import ResolutionWarning

        warnings.warn(
            f"{check.thin_components} of the {check.components} components are thinner than the spacing "
            f"{spacing:g} (parts of the model below the grid's resolution); a smaller --spacing resolves them",
            ResolutionWarning,
        )


def _write_image_triangles(args: argparse.Namespace, image, output: Path, cut: bool) -> int:
    """``fepre surface scan.zarr --level L``: an image read chunk by chunk is not sampled again
    (its refined grid is beyond memory); its level set's triangles are the surface."""
    import pyvista as pv

    if args.spacing is not None or args.bounds is not None:
        raise ValueError("--spacing and --bounds do not apply to a .zarr image: its surface is its level set's "
                         "triangles, taken chunk by chunk")
    faces = np.column_stack([np.full(len(image.faces), 3), image.faces]).ravel()
    surface = pv.PolyData(np.asarray(image.vertices), faces)
    if not args.quiet:
        common.say(f"fepre surface: the level set's {surface.n_cells} triangles"
                   + (" (closed beyond the image's border, not cut by its box)" if cut else ""))
    common.write_atomically(lambda path: surface.save(str(path)), output)
    print(f"wrote {output}")
    return 0


def run(args: argparse.Namespace) -> int:
    from ..surface import isosurface

    output = common.output_path(args.output, "--output", SURFACE_SUFFIXES)
    if args.spacing is not None and not args.spacing > 0:
        raise ValueError(f"--spacing must be > 0; got {args.spacing:g}")
    chunks = common.chunks_argument(args.chunks)
    if args.band is not None and chunks is None:
        raise ValueError("--band applies with --chunks")
    if chunks is not None or common.is_zarr_grid(args.model):
        return _run_chunked_surface(args, output, chunks, (lambda message: None) if args.quiet else common.say)
    bounds = None
    if args.bounds is not None:
        from ..arguments import as_bounds

        bounds = as_bounds((args.bounds[:3], args.bounds[3:]), 3, "--bounds")
    part = common.load_part(args)
    image = common.image_of(part.model)
    if image is not None and not isinstance(image.image.values, np.ndarray):
        return _write_image_triangles(args, image, output, part.model is not image)
    bounds = bounds if bounds is not None else part.bounds
    if args.spacing is not None:
        spacing = args.spacing
    elif bounds is not None and (args.bounds is not None or part.bounds is not None):
        spacing = max(b - a for a, b in zip(*bounds)) / 100.0
    else:
        spacing = common.default_spacing(part)
    say = (lambda message: None) if args.quiet else common.say
    say(f"fepre surface: {args.method} at spacing {spacing:g} ...")
    start = time.perf_counter()
    surface = isosurface(part.model, method=args.method, spacing=spacing, bounds=bounds,
                         level=common.surface_level(args, part.model))
    if surface.n_cells == 0:
        raise ValueError(
            f"the surface of {part.path} is empty at spacing {spacing:g} (the model is nowhere negative "
            f"inside its bounds); nothing written"
        )
    if args.no_check:
        say(f"fepre surface: {surface.n_cells} triangles in {time.perf_counter() - start:.2f} s")
    else:
        say(f"fepre surface: {surface.n_cells} triangles in {time.perf_counter() - start:.2f} s; checking ...")
        _check_surface_file(surface, part.model, spacing, args.quiet)
    say(f"fepre surface: writing {output} ...")
    common.write_atomically(lambda path: surface.save(str(path)), output)
    print(f"wrote {output}")
    return 0
