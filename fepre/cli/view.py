"""``fepre view``: show a mesh (its interior coloured by quality), a surface or a model file."""

from __future__ import annotations

import argparse
from pathlib import Path

from . import common
from . import files


HELP = "show a mesh (its interior coloured by quality), a surface or a model file"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE", help="a mesh or surface file (VTU, VTK, STL, INP, MSH, ...) or a MODEL.py")
    parser.add_argument("--screenshot", metavar="PNG", help="render off screen and save a PNG instead of opening a window")
    parser.add_argument("--metric", default="min_dihedral_angle",
                        help="cell quality to colour tetrahedra by (default min_dihedral_angle), or region_id for the material regions")
    parser.add_argument("--no-clip", action="store_true", help="show the whole mesh instead of its interior")
    parser.add_argument("--clip", metavar="AXIS[=VALUE]",
                        help="clip plane of a mesh: normal x, y or z, through VALUE (default the centre), e.g. z=0.5")
    parser.add_argument("--slice", metavar="AXIS[=VALUE]",
                        help="show only the section of a mesh on this plane (e.g. y=0 through a lattice infill)")


def run(args: argparse.Namespace) -> int:
    from .. import plotting

    common.output_path(args.screenshot, "--screenshot", (".png",))
    if args.clip and args.slice:
        raise ValueError("give --clip or --slice, not both")
    if (args.clip or args.slice) and args.no_clip:
        raise ValueError(f"--no-clip contradicts {'--clip' if args.clip else '--slice'}")
    plane = _plane(args.clip, "--clip") if args.clip else _plane(args.slice, "--slice") if args.slice else ("x", None)
    off_screen = True if args.screenshot else None
    if not args.screenshot and not plotting.has_display():
        raise ValueError("no display to open a window on; pass --screenshot out.png to render off screen")
    if args.file.endswith(".py"):
        from ..modelfile import load_model

        part = load_model(args.file)
        path = plotting.plot_model(part.model, bounds=part.bounds, off_screen=off_screen, screenshot=args.screenshot)
    else:
        mesh, _ = files.read_mesh(args.file)
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
