"""Ordinary CAD parts for the automatic size field: bosses, ribs, webs, pockets, drafts, holes,
touching unions and smooth unions, in millimetres, each with the sizes ``(hmin, hmax)`` an
engineer would mesh it at, its thinnest wall and its volume.

Volumes are exact where the part is built of boxes, cylinders and frustums that touch or
overlap along known solids; the smooth unions (conrod, blended tee) have no closed form and
carry a Monte Carlo reference (:data:`MONTE_CARLO_SAMPLES` samples in the part's box, seed 0;
the standard error is given). ``fepre bench sizing --set cad`` meshes them (issue 33's targets).

Examples
--------
>>> from fepre.cad_parts import cad_parts
>>> parts = {p.name: p for p in cad_parts()}
>>> ibeam = parts["I-beam"]
>>> ibeam.volume, ibeam.hmin, ibeam.wall
(7200.0, 1.5, 3.0)
>>> float(ibeam.model([0.0, 0.0, 0.0])) < 0   # in the web
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import sdf

__all__ = ["CadPart", "cad_parts", "MONTE_CARLO_SAMPLES"]

#: samples behind the reference volumes of the smooth unions
MONTE_CARLO_SAMPLES = 40_000_000


@dataclass(frozen=True)
class CadPart:
    """A named part: ``model``, ``volume`` (exact, or a reference with standard error
    ``volume_error``), the sizes ``hmin``, ``hmax`` to mesh it at and ``wall``, its thinnest
    wall (the field's target ``min >= hmin / 2`` holds where walls are at least ``3 hmin``)."""

    name: str
    model: sdf.SDF
    volume: float
    hmin: float
    hmax: float
    wall: float
    volume_error: float = 0.0  # standard error of a Monte Carlo reference; 0 for exact volumes
    note: str = ""


def _rounded_box_volume(a: float, b: float, c: float, r: float) -> float:
    """Volume of ``sdf.rounded_box((a, b, c), r)``: the box shrunk by ``r``, grown by ``r``."""
    x, y, z = a - 2 * r, b - 2 * r, c - 2 * r
    return x * y * z + 2 * r * (x * y + y * z + x * z) + math.pi * r * r * (x + y + z) + 4.0 / 3.0 * math.pi * r**3


def _rounded_rectangle_area(a: float, b: float, r: float) -> float:
    return a * b - (4.0 - math.pi) * r * r


def ibeam() -> CadPart:
    """Two flanges 40 x 20 x 3 and a web 40 x 3 x 20 that touch them face to face."""
    flanges = sdf.box((40, 20, 3), center=(0, 0, 11.5)) | sdf.box((40, 20, 3), center=(0, 0, -11.5))
    return CadPart("I-beam", flanges | sdf.box((40, 3, 20)), 2 * 40 * 20 * 3 + 40 * 3 * 20.0, 1.5, 6.0, 3.0)


def plate_boss_bore() -> CadPart:
    """A 30 x 30 x 5 plate, a boss of radius 6 and height 10 standing on it, a bore of radius 3."""
    plate = sdf.box((30, 30, 5), center=(0, 0, 2.5))
    boss = sdf.cylinder(6.0, 10.0, center=(0, 0, 10.0))
    model = (plate | boss) - sdf.cylinder(3.0, 40.0)
    return CadPart("plate, boss, bore", model, 4500.0 + math.pi * (36.0 * 10.0 - 9.0 * 15.0), 1.0, 6.0, 3.0)


def conrod() -> CadPart:
    """A connecting rod: bosses (radius 16 and 10, bores 9 and 5) joined by an I-section shank
    (flanges 3 wide, web 4 thick) in a smooth union (k = 4)."""
    big = sdf.cylinder(16.0, 14.0, center=(-40.0, 0, 0))
    small = sdf.cylinder(10.0, 12.0, center=(40.0, 0, 0))
    shank = (sdf.box((64, 3, 12), center=(0, 6.5, 0)) | sdf.box((64, 3, 12), center=(0, -6.5, 0))
             | sdf.box((64, 10, 4)))
    model = sdf.union(big, small, shank, k=4.0) - sdf.cylinder(9.0, 30.0, center=(-40.0, 0, 0))
    model = model - sdf.cylinder(5.0, 30.0, center=(40.0, 0, 0))
    return CadPart("conrod", model, 17393.7, 1.5, 6.0, 3.0, 4.8, "smooth union; Monte Carlo volume")


def enclosure() -> CadPart:
    """A 60 x 40 x 20 box open at the top, walls and floor 2 thick, two ribs 2 thick standing on
    the floor and touching the side walls."""
    shell = sdf.box((60, 40, 20), center=(0, 0, 10)) - sdf.box((56, 36, 20), center=(0, 0, 12))
    ribs = sdf.box((2, 36, 8), center=(-10, 0, 6)) | sdf.box((2, 36, 8), center=(10, 0, 6))
    return CadPart("enclosure, ribs", shell | ribs, 60 * 40 * 20 - 56 * 36 * 18 + 2 * 2 * 36 * 8.0, 1.5, 6.0, 2.0)


def tube_clamp() -> CadPart:
    """A 60 x 30 x 8 base, a tube of radius 12 along y tangent to its top (bore 8), two bolt holes."""
    base = sdf.box((60, 30, 8)).translate((0, 0, 4))
    tube = sdf.cylinder(radius=12, height=30, axis="y").translate((0, 0, 20))
    bore = sdf.cylinder(radius=8, height=40, axis="y").translate((0, 0, 20))
    bolts = sdf.cylinder(radius=3, height=30).translate((22, 0, 0)) | sdf.cylinder(radius=3, height=30).translate((-22, 0, 0))
    volume = 60 * 30 * 8 + math.pi * 30 * (144 - 64) - 2 * math.pi * 9 * 8
    return CadPart("tube clamp", (base | tube) - bore - bolts, volume, 1.5, 6.0, 4.0, note="tube tangent to the base")


def rib_bracket() -> CadPart:
    """An L-bracket (base 60 x 40 x 8, upright 60 x 8 x 40) with two triangular gussets 6
    thick touching both, and two bolt holes of radius 4 in the base."""
    base = sdf.box((60, 40, 8), center=(0, 0, 4))
    upright = sdf.box((60, 8, 40), center=(0, 16, 20))
    model = base | upright
    for x in (-20.0, 20.0):  # legs 28 along y (y -16..12) and z (z 8..36); hypotenuse z - y = 24
        gusset = sdf.box((6, 28, 28), center=(x, -2, 22)) & sdf.plane((0, -1, 1), point=(0, -16, 8))
        model = model | gusset
    for x in (-8.0, 8.0):
        model = model - sdf.cylinder(4.0, 10.0, center=(x, -8.0, 4.0))
    volume = 60 * 40 * 8 + 60 * 8 * 40 - 60 * 8 * 8 + 2 * 6 * 28 * 28 / 2 - 2 * math.pi * 16 * 8
    return CadPart("rib bracket", model, volume, 1.5, 6.0, 6.0)


def drafted_boss() -> CadPart:
    """A 40 x 40 x 6 plate with a boss drafted 11.3 degrees (a frustum, radius 10 at its foot,
    7.6 at its top 12 higher) and a bore of radius 3 through both."""
    plate = sdf.box((40, 40, 6), center=(0, 0, 3))
    frustum = sdf.cone(10.0, 50.0, center=(0, 0, 6.0)) & sdf.box((30, 30, 12), center=(0, 0, 12.0))
    model = (plate | frustum) - sdf.cylinder(3.0, 60.0)
    top = 10.0 * (1 - 12.0 / 50.0)
    volume = 9600.0 + math.pi * 12.0 / 3.0 * (100.0 + 10.0 * top + top * top) - math.pi * 9.0 * 18.0
    return CadPart("drafted boss", model, volume, 1.5, 6.0, 4.6)


def stepped_shaft() -> CadPart:
    """Three coaxial cylinders stacked face to face: radius 5 for 30, 10 for 20, 7.5 for 25."""
    model = (sdf.cylinder(5.0, 30.0, center=(0, 0, 15.0)) | sdf.cylinder(10.0, 20.0, center=(0, 0, 40.0))
             | sdf.cylinder(7.5, 25.0, center=(0, 0, 62.5)))
    return CadPart("stepped shaft", model, math.pi * (25.0 * 30 + 100.0 * 20 + 56.25 * 25), 1.0, 6.0, 10.0)


def cross_ribs() -> CadPart:
    """A 60 x 60 x 3 plate with three ribs each way (2 thick, 8 high) crossing on it."""
    model = sdf.box((60, 60, 3), center=(0, 0, 1.5))
    for c in (-15.0, 0.0, 15.0):
        model = model | sdf.box((2, 60, 8), center=(c, 0, 7)) | sdf.box((60, 2, 8), center=(0, c, 7))
    return CadPart("cross ribs", model, 60 * 60 * 3 + 6 * 2 * 60 * 8 - 9 * 2 * 2 * 8.0, 1.5, 6.0, 2.0)


def blended_tee() -> CadPart:
    """A solid pipe tee: a cylinder of radius 10 along x (60 long) and a branch of radius 7 up
    to z = 25, in a smooth union (k = 3)."""
    run = sdf.cylinder(10.0, 60.0, axis="x")
    branch = sdf.cylinder(7.0, 25.0, center=(0, 0, 12.5))
    return CadPart("blended tee", sdf.union(run, branch, k=3.0), 21347.0, 1.5, 6.0, 14.0, 3.8,
                   "smooth union; Monte Carlo volume")


def pocket_block() -> CadPart:
    """A 50 x 40 x 20 block with a 30 x 20 pocket 12 deep in its top and a hole of radius 4
    through the pocket's floor."""
    model = sdf.box((50, 40, 20), center=(0, 0, 10)) - sdf.box((30, 20, 24), center=(0, 0, 20))
    model = model - sdf.cylinder(4.0, 30.0, center=(0, 0, 4.0))
    return CadPart("pocket block", model, 40000.0 - 30 * 20 * 12 - math.pi * 16 * 8, 1.5, 6.0, 8.0)


def flange() -> CadPart:
    """A disk of radius 30, 6 thick, under a hub of radius 12 (20 high), a bore of radius 7
    and six bolt holes of radius 3 on a circle of radius 22."""
    model = (sdf.cylinder(30, 6).translate((0, 0, 3)) | sdf.cylinder(12, 20).translate((0, 0, 10))) - sdf.cylinder(7, 50)
    for k in range(6):
        angle = math.pi * k / 3
        model = model - sdf.cylinder(3, 20).translate((22 * math.cos(angle), 22 * math.sin(angle), 3))
    volume = math.pi * (30**2 * 6 + 12**2 * 14 - 7**2 * 20 - 6 * 3**2 * 6)
    return CadPart("flange", model, volume, 1.0, 6.0, 5.0)


def rounded_housing() -> CadPart:
    """A 50 x 40 x 30 box with edges rounded at 2.5, hollowed from the top by a pocket with
    edges rounded at 2 (walls and floor 3 thick; the pocket's rim is on the flat top)."""
    outer = sdf.rounded_box((50, 40, 30), 2.5, center=(0, 0, 15))
    pocket = sdf.rounded_box((44, 34, 30), 2.0, center=(0, 0, 18))  # z 3..33: open through the top
    # the pocket's part above z = 30: its top cap (r high) and 1 of full section
    cap = (_rounded_box_volume(44, 34, 30, 2.0) - _rounded_rectangle_area(44, 34, 2.0) * 26) / 2
    inside = _rounded_box_volume(44, 34, 30, 2.0) - cap - _rounded_rectangle_area(44, 34, 2.0) * 1.0
    return CadPart("rounded housing", outer - pocket, _rounded_box_volume(50, 40, 30, 2.5) - inside, 1.0, 6.0, 3.0)


def v_groove_block() -> CadPart:
    """A 40 x 20 x 10 block with a V-groove 30 degrees open, 6 deep, along y (a concave junction)."""
    opening = math.tan(math.radians(15.0))
    groove = sdf.plane((1.0, 0.0, -opening), point=(0, 0, 4)) & sdf.plane((-1.0, 0.0, -opening), point=(0, 0, 4))
    model = sdf.box((40, 20, 10), center=(0, 0, 5)) - groove
    return CadPart("V-groove block", model, 8000.0 - 20 * 6 * 6 * opening, 1.5, 6.0, 10.0)


def cad_parts() -> list[CadPart]:
    """The parts, in the order the benchmark prints them."""
    return [ibeam(), plate_boss_bore(), conrod(), enclosure(), tube_clamp(), rib_bracket(), drafted_boss(),
            stepped_shaft(), cross_ribs(), blended_tee(), pocket_block(), flange(), rounded_housing(), v_groove_block()]
