"""What the commands share: progress lines, output paths checked before any work, atomic
writes, the model-file argument and the edge-length, period, bounds and chunk options."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Callable

import numpy as np


_LOG = None


def start_log() -> None:
    """A fresh progress log: its times count from now (the start of a command)."""
    global _LOG
    from ..progress import StepLog

    _LOG = StepLog()


def say(message: str) -> None:
    """Progress on stderr, so stdout keeps only results: one line per step with the time since
    the command started (:class:`fepre.progress.StepLog`)."""
    global _LOG
    if _LOG is None:
        from ..progress import StepLog

        _LOG = StepLog()
    _LOG(message)


def write_atomically(save: Callable[[Path], None], path: Path) -> None:
    """Call ``save(temporary)`` then rename onto ``path`` (nothing half-written)."""
    from ..export.atomic import staged_files

    with staged_files(path, [path.name], overwrite=True) as stage:
        save(stage / path.name)


def output_path(value: str | None, flag: str, suffixes: tuple[str, ...]) -> Path | None:
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


def mesh_suffixes() -> tuple[str, ...]:
    from ..export import FORMATS

    return tuple(ext for f in FORMATS.values() for ext in f.extensions)


def companions(output: Path, fmt) -> list[Path]:
    """The files format ``fmt`` writes beside ``output`` (XDMF: its .h5 and the facets pair)."""
    return [output.with_name(name) for name in fmt.outputs(output.name) if name != output.name]


def model_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", metavar="MODEL",
                        help="Python file defining `model` (and optionally h, bounds, boundaries), "
                             "a surface mesh file (STL, OBJ, PLY, OFF, VTP, VTK) to use as the model, the boundary of a "
                             "volume mesh file (VTU, MESH, MSH, INP) to remesh, a CAD file (STEP, BREP) tessellated, "
                             "or an image (.vti, .nii, .nii.gz, .tif, .zarr) with --level")
    parser.add_argument("--inside", choices=("closed", "winding", "above", "below"),
                        help="for a surface mesh file: the solid is what the repaired surface encloses (closed, the default; "
                             "open surfaces with large holes are refused) or where its generalised winding number exceeds 1/2 "
                             "(winding: scans with large openings, overlapping open sheets); for an image: the part is where "
                             "the image is above the level (the default) or below it")


def image_arguments(parser: argparse.ArgumentParser, level: bool = True) -> None:
    """The options of an image given as MODEL (``--level`` unless the command has its own)."""
    if level:
        parser.add_argument("--level", type=float,
                            help="for an image MODEL: the grey value of the part's boundary")
    parser.add_argument("--smoothing", type=float,
                        help="for an image MODEL: Gaussian blur in voxels before the level is taken (noisy scans; "
                             "default 0, for --labels 0.5)")
    parser.add_argument("--array", metavar="NAME",
                        help="for an image MODEL with several arrays (a .vti) or a zarr group: the one to read "
                             "(default its active scalars or its only array)")
    parser.add_argument("--partial-volume", action="store_true",
                        help="for an image MODEL whose values are partial volumes or a scan's blur of one material on "
                             "one background: move the level set (by a few hundredths of a voxel) so that the part "
                             "holds the volume the values give (the midway level loses volume at edges and where the "
                             "part is curved at the voxels' scale)")
    parser.add_argument("--voxel-size", type=float, nargs="+", metavar="D",
                        help="for a TIFF stack MODEL: the voxel size, one number or three (x y z); default the size its "
                             "OME or ImageJ metadata gives, else 1")
    parser.add_argument("--origin", type=float, nargs=3, metavar=("X", "Y", "Z"),
                        help="for a TIFF stack MODEL: the position of its first voxel (default 0 0 0)")


def label_arguments(parser: argparse.ArgumentParser) -> None:
    """``--labels`` and ``--label VALUE=NAME``: an image MODEL as a label image, one region per label."""
    parser.add_argument("--labels", action="store_true",
                        help="MODEL is a label image (.vti, .nii, .nii.gz, .tif, or a .zarr store read chunk by chunk): "
                             "one region (element set) per label, meshed conformally; label 0 is the background")
    parser.add_argument("--label", action="append", metavar="VALUE=NAME",
                        help="with --labels: the region name of a label (repeat; default label_<VALUE>)")
    parser.add_argument("--fill-cracks", action="store_true",
                        help="with --labels: give each background voxel between two different labels (a crack one "
                             "voxel wide between materials that touch) the smaller of the two")


def solid_arguments(parser: argparse.ArgumentParser) -> None:
    """``--solids`` and ``--solid NUMBER=NAME``: a CAD MODEL's solids as regions."""
    parser.add_argument("--solids", action="store_true",
                        help="MODEL is a STEP or BREP assembly: one region (element set) per solid, meshed conformally "
                             "where solids touch (default: the solids united into one part)")
    parser.add_argument("--solid", action="append", metavar="NUMBER=NAME",
                        help="with --solids: the region name of a solid, numbered from 1 in the file's order "
                             "(repeat; default the solid's name in the file, else solid_<NUMBER>)")


def solid_options(args: argparse.Namespace) -> dict | None:
    """``load_model(solids=)`` from ``--solids`` and ``--solid``: None without ``--solids``."""
    if getattr(args, "solid", None) and not getattr(args, "solids", False):
        raise ValueError("--solid names a solid of a CAD assembly: add --solids")
    if not getattr(args, "solids", False):
        return None
    if getattr(args, "labels", False):
        raise ValueError("--solids is for a CAD file and --labels for a label image: give one")
    return numbered_names(args.solid or [], "--solid", "plate")


IMAGE_INSIDE = ("above", "below")


def mesh_inside(args: argparse.Namespace) -> str:
    """``--inside`` for a surface mesh file (``closed`` unless ``closed`` or ``winding`` given)."""
    inside = getattr(args, "inside", None)
    return inside if inside in ("closed", "winding") else "closed"


def image_options(args: argparse.Namespace) -> dict:
    """The options of ``sdf.image`` from the command line (the flags the command has)."""
    options = {"level": getattr(args, "level", None)}
    for name in ("inside", "smoothing", "origin", "array"):
        if getattr(args, name, None) is not None:
            options[name] = getattr(args, name)
    if getattr(args, "partial_volume", False):
        options["partial_volume"] = True
    if getattr(args, "voxel_size", None) is not None:
        spacing = args.voxel_size
        if len(spacing) not in (1, 3) or not all(np.isfinite(v) and v > 0 for v in spacing):
            raise ValueError(f"--voxel-size must be one positive number or three (x y z); got {' '.join(f'{v:g}' for v in spacing)}")
        options["spacing"] = spacing[0] if len(spacing) == 1 else tuple(spacing)
    if options.get("origin") is not None:
        if not all(np.isfinite(v) for v in options["origin"]):
            raise ValueError(f"--origin must be three finite numbers; got {' '.join(f'{v:g}' for v in options['origin'])}")
        options["origin"] = tuple(options["origin"])
    if getattr(args, "label", None) and not getattr(args, "labels", False):
        raise ValueError("--label names a region of a label image: add --labels")
    if getattr(args, "fill_cracks", False) and not getattr(args, "labels", False):
        raise ValueError("--fill-cracks is for a label image: add --labels")
    if getattr(args, "labels", False):
        if options.pop("level") is not None:
            raise ValueError("--level is for a grey image; a label image (--labels) has none")
        options.pop("inside", None)
        if options.pop("partial_volume", False):
            raise ValueError("--partial-volume is for a grey image; a label image (--labels) has no partial volumes")
        options["labels"] = True
        options["names"] = label_names(args.label or [])
        if getattr(args, "fill_cracks", False):
            options["fill_cracks"] = True
    return options


def label_names(values: list[str]) -> dict:
    """``--label 1=bone --label 2=implant`` as {1: "bone", 2: "implant"}."""
    return numbered_names(values, "--label", "bone")


def numbered_names(values: list[str], flag: str, example: str) -> dict:
    """``FLAG 1=NAME`` values as {1: "NAME"}, each checked (``example``: a name for the message)."""
    key = "VALUE" if flag == "--label" else "NUMBER"
    names = {}
    for value in values:
        number, _, name = value.partition("=")
        try:
            number = int(number)
        except ValueError:
            raise ValueError(f"{flag} must be {key}=NAME with an integer {key} (e.g. {flag} 1={example}); got {value!r}") from None
        if number in names and names[number] != name:
            raise ValueError(f"{flag} {number} is given twice ({names[number]!r} and {name!r}); give each {key} one name")
        names[number] = name
        if not name:
            raise ValueError(f"{flag} must be {key}=NAME (e.g. {flag} 1={example}); got {value!r}")
    return names


def _refuse_level(args: argparse.Namespace) -> None:
    """``--level`` is an image's grey value, except in ``fepre surface`` (the level set to extract):
    given with another model, it was ignored without a word."""
    from ..modelfile import _is_image

    if getattr(args, "level", None) is None or getattr(args, "command", None) == "surface":
        return
    if not _is_image(Path(args.model)):
        raise ValueError(f"--level is the grey value of an image MODEL (.vti, .nii, .nii.gz, .tif, .zarr); "
                         f"{args.model} is not one (got --level {args.level:g})")


def load_part(args: argparse.Namespace):
    """The model file (or mesh file) of ``args.model``; for a mesh file, say what was read and
    repaired."""
    from ..modelfile import load_model
    from ..sdf import MeshModel
    from ..sdf.imagemodel import LabelModel

    _refuse_level(args)
    part = load_model(args.model, image=image_options(args), inside=mesh_inside(args), solids=solid_options(args))
    image = image_of(part.model)
    if image is not None:
        if not getattr(args, "quiet", False):
            voxels = " x ".join(map(str, image.image.values.shape))
            say(f"{part.path}: {voxels} voxels of {voxel_size(image.image)}, level {image.level:g} ({image.inside}): "
                f"{len(image.faces)} triangles" + ("; cut by the image's box" if image is not part.model else "")
                + partial_volume_note(image, whole=image is part.model))
    elif part.regions and isinstance(next(iter(part.regions.values())), LabelModel):
        if not getattr(args, "quiet", False):
            first = next(iter(part.regions.values()))
            voxels = " x ".join(map(str, first.image.values.shape))
            listed = ", ".join(f"{name} ({model.label})" for name, model in part.regions.items() if hasattr(model, "label"))
            say(f"{part.path}: label image of {voxels} voxels of {voxel_size(first.image)}; regions {listed}")
    elif getattr(args, "solids", False):
        if not getattr(args, "quiet", False):
            listed = ", ".join(f"{name} (volume {model.volume:.6g})" for name, model in part.regions.items())
            say(f"{part.path}: {len(part.regions)} solid(s), one region each: {listed}")
    elif isinstance(part.model, MeshModel) and not getattr(args, "quiet", False):
        repaired = part.model.repaired.summary()
        # where shells cross, their triangles are split into loose pieces at the seams, each a
        # smooth piece of its own: two touching boxes of 11,688 triangles read "18679 smooth pieces"
        pieces = ("" if part.model.repaired.internal else f", {part.model.patch_count} smooth pieces")
        say(f"{part.path}: {len(part.model.faces)} triangles{pieces}"
             + (f"; repaired: {repaired}" if repaired else "; closed and consistently oriented"))
    return part


#: images up to this many voxels get the header's hint on --partial-volume (it reads them whole)
HINT_VOXELS = 20_000_000


def partial_volume_note(image, whole: bool = True) -> str:
    """The header line's note on ``--partial-volume``: the phases, the volume and the shift; or,
    without it, for an image in memory and not cut by its box (``whole``), the volume its values
    would give when the level set holds more than 1% less or more."""
    found = image.partial_volume
    if found is None:
        values = image.image.values
        if not whole or not isinstance(values, np.ndarray) or values.size > HINT_VOXELS:
            return ""
        from ..sdf.imagemodel.partial_volume import values_volume

        given = values_volume(image.image, image.level, image.inside)
        held = abs(float(image.volume))
        if given is None or abs(held / given - 1.0) <= 0.01:
            return ""
        return (f"; the level set holds {held:.6g}, {100 * abs(held / given - 1.0):.1f}% "
                f"{'less' if held < given else 'more'} than the {given:.6g} its values give if they are partial "
                f"volumes or a scan's blur of one material (--partial-volume keeps that; not for a density)")
    return (f"; partial volumes (background {found.background:g}, material {found.material:g}): volume "
            f"{found.volume:.6g} at level {found.level:.6g}, the surface moved {found.shift / float(max(image.spacing)):+.3f} "
            f"voxel on average from {found.level_set_volume:.6g}")


def voxel_size(image) -> str:
    """An image's spacing for the header line, saying when it is the default 1 (a TIFF stack
    that gives none)."""
    spacing = " x ".join(f"{v:g}" for v in image.spacing)
    if getattr(image, "spacing_from", "image") == "default":
        spacing += " (the file gives no voxel size: --voxel-size sets it)"
    return spacing


def image_of(model):
    """The :class:`fepre.sdf.ImageModel` of an image model (itself, or the one its box cuts), else None."""
    from ..sdf import ImageModel

    if isinstance(model, ImageModel):
        return model
    children = model.children
    return children[0] if len(children) == 2 and isinstance(children[0], ImageModel) else None


def surface_level(args: argparse.Namespace, model) -> float:
    """The level ``fepre surface`` extracts: ``--level``, except for an image (whose --level is its grey value)."""
    return 0.0 if args.level is None or (model is not None and image_of(model) is not None) else float(args.level)


def default_spacing(part) -> float:
    image = image_of(part.model)
    if image is not None:  # the grid the image's level set was taken on
        return float(image.spacing.min()) / image.refine
    lo, hi = part.domain_bounds()
    return max(b - a for a, b in zip(lo, hi)) / 100.0


def chunks_argument(values: list[int] | None):
    """``--chunks`` as nodes per chunk (x, y, z), checked."""
    if values is None:
        return None
    from ..chunked.layout import as_chunks

    if len(values) not in (1, 3):
        raise ValueError(f"--chunks takes one number or three (x y z); got {len(values)}: {values}")
    return tuple(as_chunks(values[0] if len(values) == 1 else tuple(values), "--chunks").tolist())


def is_zarr_grid(path: str) -> bool:
    """Whether ``path`` is a grid written by ``fepre.sample(store=)`` (a ``.zarr`` store marked as
    fepre's); any other ``.zarr`` store is an image (``--level``)."""
    if Path(path).suffix.lower() != ".zarr" or not Path(path).exists():
        return False
    try:
        import zarr

        return dict(zarr.open(str(path), mode="r").attrs).get("fepre") == "sdf-grid"
    except Exception:  # missing, not zarr, or zarr absent: open_grid says which
        return True


def bounds_argument(values):
    from ..arguments import as_bounds

    return as_bounds((values[:3], values[3:]), 3, "--bounds")


def period_argument(parser: argparse.ArgumentParser, required: bool) -> None:
    parser.add_argument("--period", type=float, nargs="+", metavar="L", required=required,
                        help="mesh one periodic cell of the model: its period (or Lx Ly Lz); the cell is the model "
                             "file's bounds, or from the origin; an .inp gets the periodic *EQUATION constraints")


def check_period_bounds(period, part) -> None:
    """The model file's bounds are the periodic cell: their extents must be the periods."""
    if period is None or part.bounds is None:
        return
    lower, upper = (np.asarray(v, dtype=np.float64) for v in part.bounds)
    if not np.allclose(upper - lower, np.broadcast_to(period, 3), rtol=1e-9, atol=0.0):
        raise ValueError(
            f"--period {' '.join(f'{v:g}' for v in np.broadcast_to(period, 3))} disagrees with the bounds in "
            f"{part.path}, whose extents are {' '.join(f'{v:g}' for v in upper - lower)} (the bounds are the cell)"
        )


def periods(values: list[float] | None):
    """The ``--period`` values as one or three positive floats, or None."""
    if values is None:
        return None
    if len(values) not in (1, 3):
        raise ValueError(f"--period takes one period or three (Lx Ly Lz); got {len(values)} numbers")
    if not all(np.isfinite(v) and v > 0 for v in values):
        raise ValueError(f"--period must be positive; got {' '.join(f'{v:g}' for v in values)}")
    return values[0] if len(values) == 1 else tuple(values)


def length(text: str) -> float | str:
    """An argparse type for an edge length: a number, or ``D/N`` (the part's bounding-box
    diagonal over N, resolved once the part is read: :func:`resolve_lengths`)."""
    from ..arguments import diagonal_lengths

    text = text.strip()
    if text[:2].upper() == "D/":
        try:
            return f"D/{1.0 / diagonal_lengths(text, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0)):g}"  # N, checked
        except ValueError:
            pass
        raise argparse.ArgumentTypeError(f"D/N needs a number N > 0 (D/50: 50 elements along the part's diagonal); "
                                         f"got {text!r}")
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a length, or D/N for the part's bounding-box diagonal over N "
                                         f"(e.g. 0.5 or D/50); got {text!r}") from None
    if not (math.isfinite(value) and value > 0):  # refused before the model is read (262 s for an 84k-triangle STL)
        raise argparse.ArgumentTypeError(f"a length must be a finite number > 0, or D/N for the part's "
                                         f"bounding-box diagonal over N (e.g. 0.5 or D/50); got {text!r}")
    return value


LENGTH_HELP = "; or D/N: the part's bounding-box diagonal over N"


def resolve_lengths(args: argparse.Namespace, part) -> None:
    """``--h`` and ``--hmax`` given as ``D/N``, as numbers: the diagonal of the part's box over N."""
    for name in ("h", "hmax"):
        value = getattr(args, name, None)
        if isinstance(value, str):
            from ..arguments import diagonal_lengths

            lower, upper = part.domain_bounds()
            setattr(args, name, diagonal_lengths(value, lower, upper, f"--{name}"))
            if not getattr(args, "quiet", False):
                diagonal = float(np.linalg.norm(np.subtract(upper, lower)))
                say(f"--{name} {value}: {getattr(args, name):.6g} (the part's box has a diagonal of {diagonal:.6g})")


def require_edge_length(args: argparse.Namespace) -> None:
    """A mesh, CAD or image file carries no edge length: without ``--h`` (or ``--size``) say so
    before the file is read (a STEP file's tessellation takes seconds)."""
    if args.h is None and getattr(args, "size", None) is None and not str(args.model).endswith(".py"):
        raise ValueError(f"no edge length: pass --h, an edge length in the units of {args.model}, or --h D/N for "
                         "the part's bounding-box diagonal over N (--h D/50: about 50 elements along it)")
    hmax = getattr(args, "hmax", None)
    if isinstance(args.h, float) and isinstance(hmax, float) and not hmax > args.h:
        raise ValueError(f"--hmax must be larger than --h; got --hmax {hmax:g} and --h {args.h:g}")
    if isinstance(args.h, str) and isinstance(hmax, str) and not _diagonal_count(hmax) < _diagonal_count(args.h):
        raise ValueError(f"--hmax must be larger than --h; got --hmax {hmax} and --h {args.h} (D/N: a larger N is "
                         "a smaller length)")


def _diagonal_count(text: str) -> float:
    """N of a checked ``D/N``."""
    return float(text[2:])


def edge_length(args: argparse.Namespace, part) -> float:
    resolve_lengths(args, part)
    h = args.h if args.h is not None else part.h
    if h is None:
        if part.path.suffix == ".py":
            raise ValueError(f"no edge length: pass --h or set `h = ...` in {part.path}")
        lower, upper = part.domain_bounds()
        extent = max(b - a for a, b in zip(lower, upper))
        raise ValueError(f"no edge length: pass --h (the part in {part.path} is {extent:.4g} across; --h {extent / 20:.2g} puts about 20 elements across it)")
    flag = edge_length_flag(args, part)
    if not (math.isfinite(h) and h > 0):
        raise ValueError(f"{flag} must be a finite number > 0; got {h}")
    if getattr(args, "hmax", None) is not None and not math.isfinite(args.hmax):
        raise ValueError(f"--hmax must be a finite number larger than --h; got {args.hmax}")
    return float(h)


def edge_length_flag(args: argparse.Namespace, part) -> str:
    """Where the edge length came from, for messages: ``--h``, or the model file's ``h``."""
    return "--h" if args.h is not None else f"h in {part.path}"


def check_edge_length(args: argparse.Namespace, h: float, part) -> None:
    """``h`` below the part's largest extent, or a ValueError naming where it came from (before meshing)."""
    flag = edge_length_flag(args, part)
    lower, upper = part.domain_bounds()
    extent = max(b - a for a, b in zip(lower, upper))
    if h >= extent:
        raise ValueError(f"{flag} {h:g} must be smaller than the part's largest extent {extent:.4g} ({part.path}); "
                         f"--h {extent / 20:.2g} puts about 20 elements across it")


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer; got {text!r}")
    return value


def seed_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seed", type=_seed, default=0,
                        help="seed of DistMesh's random choices (lattice jitter, size rejection); the same seed "
                             "gives the same mesh (default 0)")
