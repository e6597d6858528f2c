"""The ``fepre`` command.

Subcommands are small functions registered in ``COMMANDS``; each gets its own argparse
sub-parser. Errors meant for users are printed without a traceback (exit code 1; bad usage 2).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

from . import __version__
from .errors import MeshingError

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


_LOG = None


def _say(message: str) -> None:
    """Progress on stderr, so stdout keeps only results: one line per step with the time since
    the command started (:class:`fepre.progress.StepLog`)."""
    global _LOG
    if _LOG is None:
        from .progress import StepLog

        _LOG = StepLog()
    _LOG(message)


def _write_atomically(save: Callable[[Path], None], path: Path) -> None:
    """Call ``save(temporary)`` then rename onto ``path`` (nothing half-written)."""
    from .export.atomic import staged_files

    with staged_files(path, [path.name], overwrite=True) as stage:
        save(stage / path.name)


def _output_path(value: str | None, flag: str, suffixes: tuple[str, ...]) -> Path | None:
    """``value`` as an output path, checked before any work: suffix, folder, writability."""
    import os

    if value is None:
        return None
    path = Path(value)
    if path.suffix.lower() not in suffixes:
        listed = ", ".join(suffixes[:-1]) + (" or " if len(suffixes) > 1 else "") + suffixes[-1]
        raise ValueError(f"{flag} must end in {listed}; got {path.name!r}")
    if path.is_dir():
        raise ValueError(f"{flag} {value!r} is a folder; give a file name")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ValueError(f"{flag} {value!r}: the folder {str(folder)!r} does not exist; create it first")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"{flag} {value!r}: the folder {str(folder)!r} is not writable")
    return path


SURFACE_SUFFIXES = (".stl", ".ply", ".obj", ".vtp", ".vtk")


def _mesh_suffixes() -> tuple[str, ...]:
    from .export import FORMATS

    return tuple(ext for f in FORMATS.values() for ext in f.extensions)


def _model_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", metavar="MODEL",
                        help="Python file defining `model` (and optionally h, bounds, boundaries), "
                             "or a surface mesh file (STL, OBJ, PLY, OFF, VTP, VTK) to use as the model")


def _load_part(args: argparse.Namespace):
    """The model file (or mesh file) of ``args.model``; for a mesh file, say what was read and
    repaired."""
    from .modelfile import load_model
    from .sdf import MeshModel

    part = load_model(args.model)
    if isinstance(part.model, MeshModel) and not getattr(args, "quiet", False):
        repaired = part.model.repaired.summary()
        _say(f"{part.path}: {len(part.model.faces)} triangles, {part.model.patch_count} smooth pieces"
             + (f"; repaired: {repaired}" if repaired else "; closed and consistently oriented"))
    return part


def _default_spacing(part) -> float:
    lo, hi = part.domain_bounds()
    return max(b - a for a, b in zip(lo, hi)) / 100.0


def _configure_surface(parser: argparse.ArgumentParser) -> None:
    _model_argument(parser)
    parser.add_argument("-o", "--output", required=True, help="surface file: .stl, .ply, .obj or .vtp")
    parser.add_argument("--method", default="flying_edges",
                        choices=("flying_edges", "marching_cubes", "marching_tetrahedra", "surface_nets",
                                 "dual_contouring"),
                        help="extraction method (dual_contouring keeps sharp edges and corners)")
    parser.add_argument("--spacing", type=float, help="grid spacing (default: largest extent / 100)")
    parser.add_argument("--level", type=float, default=0.0,
                        help="the level set to extract (default 0: the part's surface; > 0 an offset outward)")
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


def _chunks_argument(values: list[int] | None):
    """``--chunks`` as nodes per chunk (x, y, z), checked."""
    if values is None:
        return None
    from .chunked.layout import as_chunks

    if len(values) not in (1, 3):
        raise ValueError(f"--chunks takes one number or three (x y z); got {len(values)}: {values}")
    return tuple(as_chunks(values[0] if len(values) == 1 else tuple(values), "--chunks").tolist())


def _is_zarr_grid(path: str) -> bool:
    return Path(path).suffix.lower() == ".zarr"


def _run_chunked_surface(args: argparse.Namespace, output: Path, chunks, say) -> int:
    """``fepre surface --chunks``: from a model file or a zarr grid; .stl and .ply outputs are streamed."""
    from .chunked import open_grid, write_isosurface
    from .chunked.api import isosurface_chunked

    if _is_zarr_grid(args.model):
        if args.spacing is not None or args.bounds is not None or args.band is not None:
            raise ValueError("--spacing, --bounds and --band apply to a model file; the zarr grid is already sampled")
        source = open_grid(args.model)
        chunks = source.chunks if chunks is None else chunks
        spacing_text = f"{float(source.spacing[0]):g}"
        options = {}
        model = None
    else:
        part = _load_part(args)
        bounds = part.bounds if args.bounds is None else _bounds_argument(args.bounds)
        spacing = args.spacing
        if spacing is None:
            spacing = max(b - a for a, b in zip(*bounds)) / 100.0 if bounds is not None else _default_spacing(part)
        source, model = part.model, part.model
        options = {"spacing": spacing, "bounds": bounds, "band": args.band}
        spacing_text = f"{spacing:g}"
    say(f"fepre surface: {args.method} at spacing {spacing_text}, chunks of {chunks} nodes ...")
    start = time.perf_counter()
    if output.suffix.lower() in (".stl", ".ply"):
        written = write_isosurface(
            source, output, method=args.method, level=args.level, chunks=chunks, log=say, **options
        )
        say(f"fepre surface: {written.n_triangles:,} triangles from {written.chunks} chunks in {written.seconds:.1f} s")
        if not args.quiet:
            state = "closed and manifold" if written.closed else (
                f"NOT closed: {written.open_edges} open and {written.nonmanifold_edges} non-manifold edges")
            print(f"streamed surface: {written.n_triangles} triangles, {written.seam_edges} edges on chunk seams, {state}")
        print(f"wrote {output}")
        return 0
    surface = isosurface_chunked(
        source, method=args.method, level=args.level, chunks=chunks, spacing=options.get("spacing"),
        shape=None, bounds=options.get("bounds"), band=options.get("band"), model=None, normals=False,
        progress=not args.quiet,
    )
    say(f"fepre surface: {surface.n_cells} triangles in {time.perf_counter() - start:.2f} s")
    if surface.n_cells == 0:
        raise ValueError(f"the surface of {args.model} is empty at spacing {spacing_text}; nothing written")
    if not args.no_check:
        _check_surface_file(surface, model, float(spacing_text), args.quiet)
    _write_atomically(lambda path: surface.save(str(path)), output)
    print(f"wrote {output}")
    return 0


def _check_surface_file(surface, model, spacing: float, quiet: bool) -> None:
    """Print the surface check; warn about components below the grid's resolution."""
    from .surface import check_surface

    check = check_surface(surface, model)
    if not quiet:
        print(check)
    if check.thin_components:
        import warnings

        from .errors import ResolutionWarning

        warnings.warn(
            f"{check.thin_components} of the {check.components} components are thinner than the spacing "
            f"{spacing:g} (parts of the model below the grid's resolution); a smaller --spacing resolves them",
            ResolutionWarning,
        )


def _bounds_argument(values):
    from .arguments import as_bounds

    return as_bounds((values[:3], values[3:]), 3, "--bounds")


@command("surface", "extract the surface of a model file and write it (STL, PLY, OBJ, VTP)")(_configure_surface)
def _run_surface(args: argparse.Namespace) -> int:
    from .surface import isosurface

    output = _output_path(args.output, "--output", SURFACE_SUFFIXES)
    if args.spacing is not None and not args.spacing > 0:
        raise ValueError(f"--spacing must be > 0; got {args.spacing:g}")
    chunks = _chunks_argument(args.chunks)
    if args.band is not None and chunks is None:
        raise ValueError("--band applies with --chunks")
    if chunks is not None or _is_zarr_grid(args.model):
        return _run_chunked_surface(args, output, chunks, (lambda message: None) if args.quiet else _say)
    bounds = None
    if args.bounds is not None:
        from .arguments import as_bounds

        bounds = as_bounds((args.bounds[:3], args.bounds[3:]), 3, "--bounds")
    part = _load_part(args)
    bounds = bounds if bounds is not None else part.bounds
    if args.spacing is not None:
        spacing = args.spacing
    elif bounds is not None:
        spacing = max(b - a for a, b in zip(*bounds)) / 100.0
    else:
        spacing = _default_spacing(part)
    say = (lambda message: None) if args.quiet else _say
    say(f"fepre surface: {args.method} at spacing {spacing:g} ...")
    start = time.perf_counter()
    surface = isosurface(part.model, method=args.method, spacing=spacing, bounds=bounds, level=args.level)
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
    _write_atomically(lambda path: surface.save(str(path)), output)
    print(f"wrote {output}")
    return 0


def _configure_sample(parser: argparse.ArgumentParser) -> None:
    _model_argument(parser)
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


@command("sample", "sample a model file on a grid: a .vti image, or a chunked zarr store for grids beyond memory")(_configure_sample)
def _run_sample(args: argparse.Namespace) -> int:
    from .sampling import sample

    chunks = _chunks_argument(args.chunks)
    if Path(args.output).suffix.lower() == ".zarr":
        output = Path(args.output)  # a store is a folder: checked below
    else:
        output = _output_path(args.output, "--output", (".vti", ".zarr"))
    if output.suffix.lower() == ".zarr" and chunks is None:
        raise ValueError("--output .zarr needs --chunks (nodes per chunk, e.g. --chunks 128)")
    if output.suffix.lower() == ".vti" and chunks is not None:
        raise ValueError("--chunks writes a .zarr store; give --output NAME.zarr (a .vti is held in memory)")
    if args.spacing is not None and not args.spacing > 0:
        raise ValueError(f"--spacing must be > 0; got {args.spacing:g}")
    if chunks is not None:
        from .chunked.sampling import check_store

        try:
            check_store(output, args.overwrite)
        except FileExistsError:
            raise ValueError(f"--output {str(output)!r} already exists; pass --overwrite to replace it") from None
        except FileNotFoundError:
            raise ValueError(f"--output {str(output)!r}: the folder {str(output.parent)!r} does not exist") from None
    part = _load_part(args)
    bounds = part.bounds if args.bounds is None else _bounds_argument(args.bounds)
    spacing = args.spacing
    if spacing is None:
        spacing = max(b - a for a, b in zip(*bounds)) / 100.0 if bounds is not None else _default_spacing(part)
    say = (lambda message: None) if args.quiet else _say
    say(f"fepre sample: spacing {spacing:g} ...")
    if chunks is None:
        grid = sample(part.model, spacing=spacing, bounds=bounds, band=args.band)
        _write_atomically(lambda path: grid.save(str(path)), output)
    else:
        import contextlib

        from .chunked.cluster import distributed_client

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


def _configure_mesh(parser: argparse.ArgumentParser) -> None:
    _model_argument(parser)
    parser.add_argument("-o", "--output", required=True, help="solver file: .inp, .msh, .vtu, .xdmf, .bdf, .mesh, .med")
    parser.add_argument("--h", type=float, help="target edge length (default: the model file's h); with --hmax, the smallest")
    parser.add_argument("--hmax", type=float, help="largest edge length: grade the mesh with the automatic size field from --h to this")
    parser.add_argument("--size", metavar="FILE", help="sizes to mesh with: a .vti written by `fepre size`, or a background mesh with one array of sizes")
    parser.add_argument("--order", type=int, choices=(1, 2), default=1, help="1: linear tets, 2: quadratic (curved)")
    _period_argument(parser, required=False)
    parser.add_argument("--no-regions", action="store_true",
                        help="mesh the part as one region even if the model file defines `regions`")
    parser.add_argument("--material", nargs=3, action="append", metavar=("REGION", "E", "NU"),
                        help="elastic material of a region (repeat for each; a model file's `materials` is the default); "
                             "written to an .inp as *MATERIAL and *SOLID SECTION (a mesh of one region: REGION is volume)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-features", action="store_true", help="do not keep sharp edges and corners as mesh nodes")
    parser.add_argument("--quiet", action="store_true", help="print only the written file's name and errors")


def _materials(args: argparse.Namespace, part, regions: dict, format_name: str) -> dict | None:
    """The materials to write: ``--material`` flags, else the model file's ``materials``; checked
    against the regions and the format before any meshing."""
    from .materials import elastic_material

    if args.material:
        materials = {}
        for region, young, poisson in args.material:
            try:
                materials[region] = (float(young), float(poisson))
            except ValueError:
                raise ValueError(f"--material {region} {young} {poisson}: E and NU must be numbers") from None
        source = "--material"
    elif not regions or format_name != "abaqus":
        return None  # the model file's materials are for its regions, written to .inp files only
    else:
        materials, source = dict(part.materials), f"`materials` in {part.path}"
    if not materials:
        return None
    names = list(regions) if regions else ["volume"]
    unknown = [name for name in materials if name not in names]
    if unknown:
        raise ValueError(f"{source} names {', '.join(unknown)}, not a region of the mesh (regions: {', '.join(names)})")
    missing = [name for name in names if name not in materials]
    if missing:
        raise ValueError(f"{source} must give every region a material; missing {', '.join(missing)}")
    if format_name != "abaqus":
        raise ValueError(f"{source}: only an .inp file carries materials; the output is {format_name}")
    for name, value in materials.items():
        elastic_material(value, f"{source} for {name}")
    return materials


def _period_argument(parser: argparse.ArgumentParser, required: bool) -> None:
    parser.add_argument("--period", type=float, nargs="+", metavar="L", required=required,
                        help="mesh one periodic cell of the model: its period (or Lx Ly Lz); the cell is the model "
                             "file's bounds, or from the origin; an .inp gets the periodic *EQUATION constraints")


def _check_period_bounds(period, part) -> None:
    """The model file's bounds are the periodic cell: their extents must be the periods."""
    if period is None or part.bounds is None:
        return
    lower, upper = (np.asarray(v, dtype=np.float64) for v in part.bounds)
    if not np.allclose(upper - lower, np.broadcast_to(period, 3), rtol=1e-9, atol=0.0):
        raise ValueError(
            f"--period {' '.join(f'{v:g}' for v in np.broadcast_to(period, 3))} disagrees with the bounds in "
            f"{part.path}, whose extents are {' '.join(f'{v:g}' for v in upper - lower)} (the bounds are the cell)"
        )


def _periods(values: list[float] | None):
    """The ``--period`` values as one or three positive floats, or None."""
    if values is None:
        return None
    if len(values) not in (1, 3):
        raise ValueError(f"--period takes one period or three (Lx Ly Lz); got {len(values)} numbers")
    if not all(np.isfinite(v) and v > 0 for v in values):
        raise ValueError(f"--period must be positive; got {' '.join(f'{v:g}' for v in values)}")
    return values[0] if len(values) == 1 else tuple(values)


def _edge_length(args: argparse.Namespace, part) -> float:
    h = args.h if args.h is not None else part.h
    if h is None:
        if part.path.suffix == ".py":
            raise ValueError(f"no edge length: pass --h or set `h = ...` in {part.path}")
        lower, upper = part.domain_bounds()
        extent = max(b - a for a, b in zip(lower, upper))
        raise ValueError(f"no edge length: pass --h (the part in {part.path} is {extent:.4g} across; --h {extent / 20:.2g} puts about 20 elements across it)")
    if not h > 0:
        raise ValueError(f"--h must be > 0; got {h}")
    return float(h)


@command("mesh", "mesh a model file with tetrahedra and write a solver file")(_configure_mesh)
def _run_mesh(args: argparse.Namespace) -> int:
    import fepre

    from .modelfile import load_model
    from .quality import summary

    output = _output_path(args.output, "--output", _mesh_suffixes())
    size = _size_file(args.size) if args.size is not None else None
    period = _periods(args.period)
    part = _load_part(args)
    _check_period_bounds(period, part)
    if period is None:
        part.domain_bounds()  # an unbounded model without `bounds`: the model-file hint, before any work
    elif args.hmax is not None or size is not None:
        raise ValueError("--period meshes with one --h (no --hmax or --size)")
    h = _edge_length(args, part) if size is None or args.h is not None or part.h is not None else None
    if args.hmax is not None:
        if h is None or not args.hmax > h:
            raise ValueError(f"--hmax must be larger than --h; got --hmax {args.hmax:g} and --h {h}")
        h = (h, float(args.hmax))
    from .export.formats import resolve_format
    from .export.meshio_formats import require_module

    fmt = resolve_format(output, None)
    if args.order not in fmt.orders:
        raise ValueError(f"--order {args.order}: format {fmt.name} ({output.suffix}) supports order {fmt.orders[0]} only")
    if fmt.backend is not None:
        require_module(*fmt.backend, fmt.name)
    regions = {} if args.no_regions else part.regions
    if regions and period is not None:
        raise ValueError(f"--period: {part.path} defines `regions`; a periodic cell is meshed as one region (add --no-regions)")
    materials = _materials(args, part, regions, fmt.name)
    say = (lambda message: None) if args.quiet else _say
    if regions:
        say(f"fepre mesh: {len(regions)} regions ({', '.join(regions)}), meshed with conforming interfaces")
    if isinstance(h, tuple):
        say(f"fepre mesh: DistMesh with the automatic size field, h from {h[0]:g} to {h[1]:g} ...")
    elif size is not None:
        say(f"fepre mesh: DistMesh with the sizes of {args.size} ...")
    else:
        say(f"fepre mesh: DistMesh h={h:g} ...")
    start = time.perf_counter()
    mesh = fepre.distmesh(part.model, h, bounds=part.bounds, size=size, progress=not args.quiet, seed=args.seed,
                          features=not args.no_features, periodic=period, regions=regions or None)
    if regions:
        names = list(mesh.field_data["region_names"])
        for index, name in enumerate(names):
            chosen = np.asarray(mesh["region_id"]) == index
            say(f"fepre mesh: region {name}: {int(chosen.sum())} tetrahedra, volume {float(mesh['volume'][chosen].sum()):.6g}, "
                f"worst dihedral {float(mesh['min_dihedral_angle'][chosen].min()):.1f} deg")
    if period is not None:
        say(f"fepre mesh: periodic cell: {len(fepre.periodic_nodes(mesh))} nodes tied to their partners one period away")
    say(f"fepre mesh: {mesh.n_cells} tetrahedra, {mesh.n_points} nodes in {time.perf_counter() - start:.1f} s; writing ...")
    if not args.quiet:
        print(summary(mesh))
    if part.boundaries:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", fepre.export.BoundaryWarning)
            faces = fepre.export.tag_boundaries(mesh, part.boundaries)
        counts = np.bincount(np.asarray(faces["boundary_id"]), minlength=len(part.boundaries) + 1)
        empty = [name for index, name in enumerate(part.boundaries) if counts[index] == 0]
        if empty:
            raise ValueError(
                f"boundaries {', '.join(map(repr, empty))} in {part.path} match no boundary face of the "
                f"mesh (none within a quarter of the local edge length, facing the same way); check "
                f"where their functions are zero; nothing written"
            )
    say(f"fepre mesh: writing {output} ...")
    written = fepre.export(mesh, output, order=args.order, boundaries=part.boundaries or None, model=part.model,
                           materials=materials)
    print(f"wrote {args.output} ({written.n_cells} elements of order {args.order}, {written.n_points} nodes)")
    return 0


def _size_file(path: str):
    """A size field from a file: an image of sizes (``fepre size``) or a background mesh."""
    import pyvista as pv

    from .sizing import SizeField

    file = Path(path)
    if not file.is_file():
        raise ValueError(f"--size {path}: no such file")
    try:
        data = pv.read(str(file))
    except Exception as exc:  # noqa: BLE001 - any reader failure is the user's file
        raise ValueError(f"--size {path}: cannot read it ({exc})") from None
    try:
        return SizeField.from_image(data) if isinstance(data, pv.ImageData) else data
    except ValueError as exc:
        raise ValueError(f"--size {path}: {exc}") from None


def _configure_size(parser: argparse.ArgumentParser) -> None:
    _model_argument(parser)
    parser.add_argument("-o", "--output", required=True, help="write the size field here (.vti)")
    parser.add_argument("--h", type=float, help="smallest edge length (default: the model file's h)")
    parser.add_argument("--hmax", type=float, required=True, help="largest edge length")
    parser.add_argument("--elements-across", type=float, default=3.0, help="elements through every wall (default 3)")
    parser.add_argument("--chord-tolerance", type=float, help="largest chord error on curved faces (default h/10)")
    parser.add_argument("--gradation", type=float, default=1.3, help="largest ratio of neighbouring sizes (default 1.3)")
    parser.add_argument("--no-features", action="store_true", help="do not refine where sharp edges face each other closely")


@command("size", "the automatic size field of a model file: write it as an image (.vti) to look at or edit")(_configure_size)
def _run_size(args: argparse.Namespace) -> int:
    from .modelfile import load_model
    from .sizing import size_field
    from .sizing.estimate import estimated_cells

    output = _output_path(args.output, "--output", (".vti",))
    part = _load_part(args)
    lower, upper = (np.asarray(v, dtype=np.float64) for v in part.domain_bounds())
    h = _edge_length(args, part)
    if not args.hmax > h:
        raise ValueError(f"--hmax must be larger than --h; got --hmax {args.hmax:g} and --h {h:g}")
    _say(f"fepre size: sizes from {h:g} to {args.hmax:g} ...")
    field = size_field(part.model, h, args.hmax, elements_across=args.elements_across,
                       chord_tolerance=args.chord_tolerance, gradation=args.gradation,
                       features=not args.no_features, bounds=part.bounds)
    graded = estimated_cells(part.model, field, field.hmin, lower, upper, True)
    uniform = estimated_cells(part.model, None, h, lower, upper, False)
    print(f"size field: {field.shape[0]} x {field.shape[1]} x {field.shape[2]} nodes at spacing {float(field.spacing[0]):.4g}, "
          f"sizes {field.hmin:.4g} to {field.hmax:.4g}, built in {field.seconds:.1f} s")
    print(f"estimated cells: {graded:,.0f} graded, {uniform:,.0f} uniform at h={h:g} ({graded / max(uniform, 1):.1%})")
    image = field.to_image()
    _write_atomically(lambda path: image.save(str(path)), output)
    print(f"wrote {output}")
    return 0


def _configure_features(parser: argparse.ArgumentParser) -> None:
    _model_argument(parser)
    parser.add_argument("--h", type=float, help="node spacing along the curves (default: the model file's h)")
    parser.add_argument("--angle", type=float, default=30.0, help="crease threshold in degrees (default 30)")
    parser.add_argument("-o", "--output", help="write the corners and curves here (.vtp or .vtk)")


@command("features", "find the sharp corners and edges of a model file; print and write them")(_configure_features)
def _run_features(args: argparse.Namespace) -> int:
    import fepre

    from .modelfile import load_model

    _output_path(args.output, "--output", (".vtp", ".vtk"))
    part = _load_part(args)
    part.domain_bounds()  # an unbounded model without `bounds`: the model-file hint, before any work
    h = _edge_length(args, part)
    found = fepre.features(part.model, h, angle=args.angle, bounds=part.bounds, warn=False)
    print(found)
    if args.output:
        mesh = found.to_polydata()
        _write_atomically(lambda path: mesh.save(str(path)), Path(args.output))
        print(f"wrote {args.output}")
    return 0


def _configure_compare(parser: argparse.ArgumentParser) -> None:
    _model_argument(parser)
    parser.add_argument("--h", type=float, help="target edge length (default: the model file's h)")
    parser.add_argument("--report", help="write a self-contained HTML report here")
    parser.add_argument("--references", nargs="*", default=["pytetwild"], metavar="NAME",
                        help="reference meshers: pytetwild, gmsh (default: pytetwild)")
    parser.add_argument("--surface-spacing", type=float, help="spacing of the surface the references mesh (default h/4)")
    parser.add_argument("--exact-volume", type=float, help="the part's exact volume, if known")
    parser.add_argument("--json", help="write the figures as JSON here")
    parser.add_argument("--seed", type=int, default=0)


@command("compare", "mesh a model file with fepre and reference meshers and compare them")(_configure_compare)
def _run_compare(args: argparse.Namespace) -> int:
    from .compare import compare
    from .modelfile import load_model

    _output_path(args.report, "--report", (".html", ".htm"))
    _output_path(args.json, "--json", (".json",))
    part = _load_part(args)
    part.domain_bounds()  # an unbounded model without `bounds`: the model-file hint, before any work
    h = _edge_length(args, part)
    result = compare(part.model, h, references=tuple(args.references), surface_spacing=args.surface_spacing,
                     exact_volume=args.exact_volume, bounds=part.bounds, seed=args.seed, progress=_say)
    print(result.table())
    if args.json:
        import json

        text = json.dumps(result.to_dict(), indent=2, default=str)
        _write_atomically(lambda path: path.write_text(text), Path(args.json))
        print(f"wrote {args.json}")
    if args.report:
        from .report import write_report

        write_report({part.name: result}, args.report, progress=_say)
        print(f"wrote {args.report}")
    return 0


def _configure_view(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE", help="a mesh or surface file (VTU, VTK, STL, INP, MSH, ...) or a MODEL.py")
    parser.add_argument("--screenshot", metavar="PNG", help="render off screen and save a PNG instead of opening a window")
    parser.add_argument("--metric", default="min_dihedral_angle",
                        help="cell quality to colour tetrahedra by (default min_dihedral_angle), or region_id for the material regions")
    parser.add_argument("--no-clip", action="store_true", help="show the whole mesh instead of its interior")
    parser.add_argument("--clip", metavar="AXIS[=VALUE]",
                        help="clip plane of a mesh: normal x, y or z, through VALUE (default the centre), e.g. z=0.5")
    parser.add_argument("--slice", metavar="AXIS[=VALUE]",
                        help="show only the section of a mesh on this plane (e.g. y=0 through a lattice infill)")


@command("view", "show a mesh (its interior coloured by quality), a surface or a model file")(_configure_view)
def _run_view(args: argparse.Namespace) -> int:
    from . import plotting

    _output_path(args.screenshot, "--screenshot", (".png",))
    if args.clip and args.slice:
        raise ValueError("give --clip or --slice, not both")
    if (args.clip or args.slice) and args.no_clip:
        raise ValueError(f"--no-clip contradicts {'--clip' if args.clip else '--slice'}")
    plane = _plane(args.clip, "--clip") if args.clip else _plane(args.slice, "--slice") if args.slice else ("x", None)
    off_screen = True if args.screenshot else None
    if not args.screenshot and not plotting.has_display():
        raise ValueError("no display to open a window on; pass --screenshot out.png to render off screen")
    if args.file.endswith(".py"):
        from .modelfile import load_model

        part = load_model(args.file)
        path = plotting.plot_model(part.model, bounds=part.bounds, off_screen=off_screen, screenshot=args.screenshot)
    else:
        mesh, _ = _read_mesh(args.file)
        tetrahedra = plotting.tetrahedra_of(mesh)
        if tetrahedra is not None:
            origin = None
            if plane[1] is not None:
                origin = list(tetrahedra.center)
                origin["xyz".index(plane[0])] = plane[1]
            path = plotting.plot(tetrahedra, metric=args.metric, clip=not args.no_clip, off_screen=off_screen,
                                 screenshot=args.screenshot, title=Path(args.file).name, normal=plane[0],
                                 origin=origin, slice=bool(args.slice))
        else:
            path = plotting.plot_surface(mesh, off_screen=off_screen, screenshot=args.screenshot,
                                         title=Path(args.file).name)
    if path is not None:
        print(f"wrote {path}")
    return 0


def _plane(text: str, flag: str) -> tuple[str, float | None]:
    """``"z"`` or ``"z=0.5"`` as (axis, position or None)."""
    axis, _, value = text.partition("=")
    axis = axis.strip().lower()
    if axis not in ("x", "y", "z"):
        raise ValueError(f"{flag} must be x, y or z, optionally =VALUE (e.g. z=0.5); got {text!r}")
    if not value:
        return axis, None
    try:
        position = float(value)
    except ValueError:
        raise ValueError(f"{flag} {text!r}: {value!r} is not a number") from None
    return axis, position


def _configure_info(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE", help="a mesh or surface file (VTU, VTK, STL, INP, MSH, ...)")


@command("info", "print a mesh file's counts, cell types, quality summary and named sets")(_configure_info)
def _run_info(args: argparse.Namespace) -> int:
    print(_describe_file(args.file))
    return 0


_VTK_SUFFIXES = (".vtu", ".vtk", ".vtp", ".stl", ".ply", ".obj", ".vti")


def _read_mesh(name: str):
    """(pyvista dataset, named sets {kind: {name: count}}) of a mesh file, VTK or meshio formats."""
    import pyvista as pv

    path = Path(name)
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist")
    if path.is_dir():
        raise ValueError(f"{path} is a directory; give a mesh file")
    sets: dict[str, dict[str, int]] = {}
    if path.suffix.lower() in _VTK_SUFFIXES + (".inp",):
        import warnings

        from .export.grid import FACE_FIELD, set_names

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mesh = pv.read(str(path))
        if mesh.n_points == 0 and caught:
            raise ValueError(f"{path} holds no points: {str(caught[0].message).splitlines()[0]}")
        regions, boundaries = set_names(mesh)
        if regions and "region_id" in mesh.cell_data:
            counts = np.bincount(np.asarray(mesh.cell_data["region_id"]), minlength=len(regions))
            sets["regions (cells)"] = {n: int(counts[i]) for i, n in enumerate(regions)}
        if boundaries and FACE_FIELD in mesh.field_data:
            table = np.asarray(mesh.field_data[FACE_FIELD]).reshape(-1, 3)
            counts = np.bincount(table[:, 2], minlength=len(boundaries))
            sets["boundaries (faces)"] = {n: int(counts[i]) for i, n in enumerate(boundaries)}
        elif boundaries and "boundary_id" in mesh.point_data:
            values = np.asarray(mesh.point_data["boundary_id"])
            sets["boundaries (nodes)"] = {n: int(np.count_nonzero(values == i)) for i, n in enumerate(boundaries)}
    else:
        import meshio

        try:
            raw = meshio.read(str(path))
        except Exception as exc:  # meshio raises its own ReadError and others
            raise ValueError(f"{path}: cannot read it as a mesh ({type(exc).__name__}: {exc})") from None
        mesh = pv.from_meshio(raw)
        if raw.cell_sets:
            sets["element/face sets"] = {k: int(sum(len(np.asarray(b)) for b in v)) for k, v in raw.cell_sets.items()}
        if raw.point_sets:
            sets["node sets"] = {k: int(len(v)) for k, v in raw.point_sets.items()}
        if raw.field_data:
            sets["physical groups"] = {k: int(np.asarray(v).ravel()[0]) for k, v in raw.field_data.items()}
    if mesh.n_points == 0:
        raise ValueError(f"{path} holds no points (empty, or not a valid {path.suffix} file)")
    return mesh, sets


def _describe_file(name: str) -> str:
    import pyvista as pv

    from .plotting import tetrahedra_of

    mesh, sets = _read_mesh(name)
    celltypes = np.asarray(mesh.celltypes if isinstance(mesh, pv.UnstructuredGrid) else mesh.cast_to_unstructured_grid().celltypes)
    types = {pv.CellType(int(t)).name: int(n) for t, n in zip(*np.unique(celltypes, return_counts=True))}
    lo, hi = np.asarray(mesh.bounds).reshape(3, 2).T
    lines = [
        f"{name}: {type(mesh).__name__}",
        f"points     {mesh.n_points}",
        f"cells      {mesh.n_cells}  ({', '.join(f'{k} {v}' for k, v in types.items())})",
        f"bounds     ({lo[0]:.6g}, {lo[1]:.6g}, {lo[2]:.6g}) to ({hi[0]:.6g}, {hi[1]:.6g}, {hi[2]:.6g})",
    ]
    tetrahedra = tetrahedra_of(mesh)
    if tetrahedra is not None:
        from .quality import summary

        total = float(tetrahedra.compute_cell_sizes(length=False, area=False)["Volume"].sum())
        lines.append(f"volume     {total:.6g}")
        lines.append("quality of the tetrahedra:")
        lines.extend("  " + line for line in str(summary(tetrahedra)).splitlines())
    elif isinstance(mesh, pv.PolyData):
        lines.append(f"area       {mesh.area:.6g}")
        if mesh.n_open_edges == 0 and mesh.is_all_triangles:
            lines.append(f"volume     {mesh.volume:.6g} (closed surface)")
        else:
            lines.append(f"open edges {mesh.n_open_edges}")
    for kind, named in sets.items():
        lines.append(f"{kind}: " + (", ".join(f"{k} ({v})" for k, v in named.items()) or "none"))
    if not sets:
        lines.append("named sets: none")
    return "\n".join(lines)


def _configure_homogenize(parser: argparse.ArgumentParser) -> None:
    _model_argument(parser)
    _period_argument(parser, required=True)
    parser.add_argument("--h", type=float, help="target edge length (default: the model file's h)")
    parser.add_argument("--E", type=float, required=True, help="Young's modulus of the solid")
    parser.add_argument("--nu", type=float, required=True, help="Poisson's ratio of the solid")
    parser.add_argument("--order", type=int, choices=(1, 2), default=2, help="C3D4 (1) or C3D10 (2, default)")
    parser.add_argument("-o", "--output", help="also write the cell's mesh (.vtu, .inp with its *EQUATION constraints, ...)")
    parser.add_argument("--workdir", help="an existing folder to keep CalculiX's files in")
    parser.add_argument("--json", help="write the result (stiffness, density, moduli) to this .json file")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--quiet", action="store_true", help="print only the result")


@command("homogenize", "mesh one periodic cell and compute its effective elastic stiffness in CalculiX")(_configure_homogenize)
def _run_homogenize(args: argparse.Namespace) -> int:
    import json

    import fepre

    from .periodic.homogenize import _ccx

    period = _periods(args.period)
    if not (np.isfinite(args.E) and args.E > 0):
        raise ValueError(f"--E must be a positive Young's modulus; got {args.E:g}")
    if not -1.0 < args.nu < 0.5:
        raise ValueError(f"--nu must lie in (-1, 0.5) for an isotropic solid; got {args.nu:g}")
    _ccx(None)
    output = _output_path(args.output, "--output", _mesh_suffixes()) if args.output else None
    json_path = _output_path(args.json, "--json", (".json",)) if args.json else None
    if args.workdir is not None and not Path(args.workdir).is_dir():
        raise ValueError(f"--workdir {args.workdir!r} is not an existing folder")
    part = _load_part(args)
    _check_period_bounds(period, part)
    h = _edge_length(args, part)
    say = (lambda message: None) if args.quiet else _say
    say(f"fepre homogenize: DistMesh of the periodic cell, h={h:g} ...")
    start = time.perf_counter()
    mesh = fepre.distmesh(part.model, h, bounds=part.bounds, periodic=period, progress=not args.quiet, seed=args.seed)
    say(f"fepre homogenize: {mesh.n_cells} tetrahedra in {time.perf_counter() - start:.1f} s; six load cases in CalculiX ...")
    if output is not None:
        fepre.export(mesh, output, order=args.order, model=part.model)
        say(f"fepre homogenize: wrote {output}")
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
        _write_atomically(lambda path: path.write_text(json.dumps(record, indent=2)), json_path)
        say(f"fepre homogenize: wrote {json_path}")
    return 0


def _configure_demo(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("outdir", nargs="?", default="fepre-demo", help="output folder (default ./fepre-demo)")
    parser.add_argument("--quick", action="store_true", help="coarse settings (seconds, for tests)")
    parser.add_argument("--no-references", action="store_true", help="skip the pytetwild/gmsh reference meshes")


@command("demo", "mesh the demo parts; write STL, VTU, INP and one HTML report")(_configure_demo)
def _run_demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    result = run_demo(args.outdir, quick=args.quick, references=not args.no_references, progress=_say)
    return 1 if result.failures else 0



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
    import warnings

    global _LOG
    from .progress import StepLog

    _LOG = StepLog()

    def one_line(message, category, filename, lineno, file=None, line=None) -> None:
        # a warning is news for the user, not a pointer into fepre's source
        text = str(message).strip().replace("\n", " ")
        print(f"fepre {args.command}: warning: {text}", file=sys.stderr, flush=True)

    shown = warnings.showwarning
    warnings.showwarning = one_line
    try:
        return int(run(args) or 0)
    except (ValueError, TypeError, OSError, MeshingError) as exc:
        print(f"fepre {args.command}: error: {exc}", file=sys.stderr)
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
