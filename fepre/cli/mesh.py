"""``fepre mesh``: mesh a model file with tetrahedra and write a solver file."""

from __future__ import annotations

import argparse
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np

from . import common


HELP = "mesh a model file with tetrahedra and write a solver file"


def configure(parser: argparse.ArgumentParser) -> None:
    common.model_argument(parser)
    common.image_arguments(parser)
    common.label_arguments(parser)
    common.solid_arguments(parser)
    parser.add_argument("-o", "--output", required=True, help="solver file: .inp, .msh, .vtu, .xdmf, .bdf, .mesh, .med")
    parser.add_argument("--h", type=common.length, help="target edge length (default: the model file's h); with --hmax, the smallest the size field gives "
                        "(thinner walls and narrower gaps get it too, and are named in a warning)" + common.LENGTH_HELP)
    parser.add_argument("--hmax", type=common.length, help="largest edge length: grade the mesh with the automatic size field from --h (its floor) to this"
                        + common.LENGTH_HELP)
    parser.add_argument("--size", metavar="FILE", help="sizes to mesh with: a .vti written by `fepre size`, or a background mesh with one array of sizes "
                        "(the model file's h is not used with it; --h clamps the sizes from below)")
    parser.add_argument("--order", type=int, choices=(1, 2), default=1, help="1: linear tets, 2: quadratic (curved)")
    parser.add_argument("--strict", action="store_true",
                        help="write nothing when the mesh draws a warning about its resolution or quality (parts "
                             "left out or cut off, gaps bridged, cells short of the quality targets): exit 1 instead")
    common.period_argument(parser, required=False)
    parser.add_argument("--no-regions", action="store_true",
                        help="mesh the part as one region even if the model file defines `regions`")
    parser.add_argument("--material", nargs=3, action="append", metavar=("REGION", "E", "NU"),
                        help="elastic material of a region (repeat for each; a model file's `materials` is the default); "
                             "written to an .inp as *MATERIAL and *SOLID SECTION (a mesh of one region: REGION is volume)")
    common.seed_argument(parser)
    parser.add_argument("--no-features", action="store_true", help="do not keep sharp edges and corners as mesh nodes")
    parser.add_argument("--keep-thin", action="store_true",
                        help="keep parts thinner than an element (knife edges, fin tips) with flat cells; by default the "
                             "few such places that leave cells below the quality targets are left out (at most 1%% of "
                             "the volume), named in a warning with the --h that keeps them, and so are small pieces they cut off from "
                             "the rest (nothing would hold them in a solver)")
    parser.add_argument("--max-cells", type=_cell_count, default=None, metavar="N",
                        help="largest mesh, in estimated cells, to start on (default 20000000; meshing takes about "
                             "1.4 KB of memory per cell): a finer --h is refused before any work")
    parser.add_argument("--quiet", action="store_true", help="print only the written file's name and errors")


def _cell_count(text: str) -> int:
    """``--max-cells``: a whole number of cells, at least 1 (``5e7`` or ``50000000``)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (value >= 1 and value < 1e18 and value == int(value)):
        raise argparse.ArgumentTypeError(f"expected a whole number of cells >= 1 (e.g. 50000000 or 5e7); got {text!r}")
    return int(value)


def _materials(args: argparse.Namespace, part, regions: dict, format_name: str) -> dict | None:
    """The materials to write: ``--material`` flags, else the model file's ``materials``; checked
    against the regions and the format before any meshing."""
    from ..materials import elastic_material

    if args.material:
        materials = {}
        for region, young, poisson in args.material:
            try:
                materials[region] = (float(young), float(poisson))
            except ValueError:
                raise ValueError(f"--material {region} {young} {poisson}: E and NU must be numbers") from None
        source = "--material"
    elif format_name != "abaqus":
        return None  # the model file's materials are written to .inp files only
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


def run(args: argparse.Namespace) -> int:
    import fepre

    from ..quality import summary

    output = common.output_path(args.output, "--output", common.mesh_suffixes())
    size = _size_file(args.size) if args.size is not None else None
    period = common.periods(args.period)
    common.require_edge_length(args)
    part = common.load_part(args)
    common.check_period_bounds(period, part)
    if period is None:
        part.domain_bounds()  # an unbounded model without `bounds`: the model-file hint, before any work
    elif args.hmax is not None or size is not None:
        raise ValueError("--period meshes with one --h (no --hmax or --size)")
    # --size gives the sizes: the model file's h would clamp them from below, unasked
    h = common.edge_length(args, part) if size is None or args.h is not None or args.hmax is not None else None
    if h is not None and period is None:
        common.check_edge_length(args, h, part)
    if args.hmax is not None:
        if h is None or not args.hmax > h:
            raise ValueError(f"--hmax must be larger than --h; got --hmax {args.hmax:g} and --h {h:g}")
        h = (h, float(args.hmax))
    from ..export.formats import resolve_format
    from ..export.meshio_formats import require_module

    fmt = resolve_format(output, None)
    if args.order not in fmt.orders:
        raise ValueError(f"--order {args.order}: format {fmt.name} ({output.suffix}) supports order {fmt.orders[0]} only")
    if fmt.backend is not None:
        require_module(*fmt.backend, fmt.name)
    regions = {} if args.no_regions else part.regions
    if regions and period is not None:
        raise ValueError(f"--period: {part.path} defines `regions`; a periodic cell is meshed as one region (add --no-regions)")
    materials = _materials(args, part, regions, fmt.name)
    say = (lambda message: None) if args.quiet else common.say
    if regions:
        say(f"fepre mesh: {len(regions)} regions ({', '.join(regions)}), meshed with conforming interfaces")
    if isinstance(h, tuple):
        say(f"fepre mesh: DistMesh with the automatic size field, h from {h[0]:g} to {h[1]:g} ...")
    elif size is not None:
        unused = f" (not the model file's h = {part.h:g}: pass --h to clamp the sizes from below)" if (
            h is None and part.h is not None) else ""
        say(f"fepre mesh: DistMesh with the sizes of {args.size}{unused} ...")
    else:
        say(f"fepre mesh: DistMesh h={h:g} ...")
    start = time.perf_counter()
    with _strict(args.strict):
        mesh = fepre.distmesh(part.model, h, bounds=part.bounds, size=size, progress=not args.quiet, seed=args.seed,
                              features=not args.no_features, periodic=period, regions=regions or None,
                              thin_parts="keep" if args.keep_thin else "trim",
                              **({} if args.max_cells is None else {"max_cells": args.max_cells}))
    if regions:
        names = list(mesh.field_data["region_names"])
        for index, name in enumerate(names):
            chosen = np.asarray(mesh["region_id"]) == index
            say(f"fepre mesh: region {name}: {int(chosen.sum())} tetrahedra, volume {float(mesh['volume'][chosen].sum()):.6g}, "
                f"worst dihedral {float(mesh['min_dihedral_angle'][chosen].min()):.1f} deg")
    if period is not None:
        say(f"fepre mesh: periodic cell: {len(fepre.periodic_nodes(mesh))} nodes tied to their partners one period away")
    say(f"fepre mesh: {mesh.n_cells} tetrahedra, {mesh.n_points} nodes{_pieces_note(mesh)} in "
        f"{time.perf_counter() - start:.1f} s; writing ...")
    if not args.quiet:
        print(summary(mesh))
    if part.boundaries:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", fepre.export.BoundaryWarning)
            faces = fepre.export.tag_boundaries(mesh, part.boundaries, **_set_tolerance(part))
        counts = np.bincount(np.asarray(faces["boundary_id"]), minlength=len(part.boundaries) + 1)
        empty = [name for index, name in enumerate(part.boundaries) if counts[index] == 0]
        if empty:
            raise ValueError(
                f"boundaries {', '.join(map(repr, empty))} in {part.path} match no boundary face of the "
                f"mesh (no face with its nodes on their surface, to 1e-3 of the local edge length, and "
                f"its normal along their gradient or against it); check where their functions are zero; "
                "nothing written"
            )
    say(f"fepre mesh: writing {output} ...")
    written = fepre.export(mesh, output, order=args.order, boundaries=part.boundaries or None, model=part.model,
                           materials=materials, **_set_tolerance(part))
    print(f"wrote {args.output} ({written.n_cells} elements of order {args.order}, {written.n_points} nodes)")
    if part.boundaries or regions:  # named sets, or the interfaces between regions
        print(set_areas_text(written, part.boundary_areas))
    for companion in common.companions(output, fmt):
        print(f"wrote {companion}")
    return 0


@contextmanager
def _strict(strict: bool) -> Iterator[None]:
    """With ``--strict``, the mesh's warnings about its resolution or quality (ResolutionWarning,
    ConvergenceWarning) refuse it: they are shown, then a ValueError says nothing is written."""
    if not strict:
        yield
        return
    import warnings

    from ..errors import ConvergenceWarning, ResolutionWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    for item in caught:
        warnings.warn_explicit(item.message, item.category, item.filename, item.lineno)
    serious = {str(item.message) for item in caught if issubclass(item.category, (ResolutionWarning, ConvergenceWarning))}
    if serious:
        raise ValueError(f"--strict: {len(serious)} warning(s) about the mesh's resolution or quality (above); "
                         "nothing written")


def _set_tolerance(part) -> dict:
    """The model file's ``boundary_tolerance`` as a keyword for the sets (none when unset)."""
    return {} if part.boundary_tolerance is None else {"boundary_tolerance": part.boundary_tolerance}


def set_areas_text(grid, exact: dict | None = None) -> str:
    """One line per boundary set of a tagged grid: its faces and their area (as a solver sees them:
    quadratic faces over their curved shape), and beside it the exact area the model file gave
    (``boundary_areas``) with the difference.

    fepre cannot know the exact area of an arbitrary SDF set, so it shows one only when given.

    Examples
    --------
    >>> import fepre, tempfile, os
    >>> from fepre import sdf
    >>> mesh = fepre.distmesh(sdf.box(1.0), h=0.5)
    >>> grid = fepre.export(mesh, os.path.join(tempfile.mkdtemp(), "cube.vtu"),
    ...                     boundaries={"top": sdf.plane((0, 0, 1), (0, 0, 0.5))})
    >>> print(set_areas_text(grid, {"top": 1.0}))
    boundary set top              8 faces  area 1  (exact 1: +0.000%)
    boundary set boundary        40 faces  area 5
    """
    from ..export.grid import grid_set_areas

    sets = grid_set_areas(grid)
    exact = exact or {}
    width = max(map(len, sets), default=0)
    lines = []
    for name, (count, area) in sets.items():
        line = f"boundary set {name:<{width}}  {count:>8} faces  area {area:.7g}"
        if name in exact:
            line += f"  (exact {exact[name]:.7g}: {100.0 * (area / exact[name] - 1.0):+.3f}%)"
        lines.append(line)
    return "\n".join(lines)


def _size_file(path: str):
    """A size field from a file: an image of sizes (``fepre size``) or a background mesh."""
    import pyvista as pv

    from ..sizing import SizeField

    file = Path(path)
    if not file.is_file():
        raise ValueError(f"--size {path}: no such file")
    from ..vtk_messages import vtk_messages_kept

    try:
        with vtk_messages_kept():
            data = pv.read(str(file))
    except Exception as exc:  # noqa: BLE001 - any reader failure is the user's file
        raise ValueError(f"--size {path}: cannot read it ({exc})") from None
    try:
        return SizeField.from_image(data) if isinstance(data, pv.ImageData) else data
    except ValueError as exc:
        raise ValueError(f"--size {path}: {exc}") from None


def _pieces_note(mesh) -> str:
    """``", in N pieces ..."`` when the mesh is in more than one piece not joined through faces
    (a STEP file's two separate bodies meshed without a word: each needs holding in a solver),
    else ``""``. Pieces the mesher cut off or found small are also named in its warning."""
    from ..distmesh.pieces import mesh_pieces

    counts = mesh_pieces(np.asarray(mesh.cells_dict[10]), mesh.n_points)[1] if 10 in mesh.cells_dict else []
    if len(counts) < 2:
        return ""
    return f", in {len(counts)} pieces not joined through faces ({', '.join(f'{c:,}' for c in counts[:4])}" + (
        " ..." if len(counts) > 4 else "") + " cells: a solver needs each one held)"
