"""Named parts used by the demo, the benchmarks, the tests and the examples.

Each function returns the model first, then the pieces a user would name as boundaries (holes,
faces). The sharp parts have edges and corners at known places, so meshes and surfaces can be
checked against them.

Examples
--------
>>> from fepre.parts import cube_with_hole
>>> model, hole = cube_with_hole()
>>> model([2.5, 2.5, 0.0]) > 0   # on the hole's axis: outside the part
True
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from . import sdf

__all__ = [
    "occ_surface",
    "write_mounting_block_stl",
    "imported_infill",
    "cube_with_hole",
    "CUBE_WITH_HOLE_VOLUME",
    "cube_with_hole_corners",
    "l_bracket",
    "L_BRACKET_VOLUME",
    "l_bracket_corners",
    "slotted_box",
    "SLOTTED_BOX_VOLUME",
    "slotted_box_corners",
    "gyroid_block",
    "GYROID_BLOCK_VOLUME",
]

#: Exact volume of :func:`cube_with_hole`: 125 - 5 pi.
CUBE_WITH_HOLE_VOLUME = 125.0 - 5.0 * math.pi


def cube_with_hole() -> tuple[Any, Any]:
    """The first example of Kelly's DistMesh.jl study: [0, 5]^3 minus a radius-1 cylinder along z at x = y = 2.5.

    Returns ``(model, hole)``.
    """
    hole = sdf.cylinder(radius=1.0, height=7.0, center=(2.5, 2.5, 2.5))
    return sdf.box((5, 5, 5), center=(2.5, 2.5, 2.5)) - hole, hole


def cube_with_hole_corners() -> np.ndarray:
    """The 8 corners of :func:`cube_with_hole`, (8, 3)."""
    return 5.0 * np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=float)


#: Volume of :func:`l_bracket` (no closed form): Monte Carlo with 2e7 points, 7.4092 +- 0.0025;
#: flying edges at spacing 0.01 encloses 7.4065.
L_BRACKET_VOLUME = 7.408


def l_bracket() -> tuple[Any, Any, Any]:
    """An L-bracket with a 0.3 fillet on its inner edge (smooth union) and a bolt hole.

    The base plate (4 x 2 x 0.6) and the upright (0.6 x 2 x 3) are joined by a smooth union of
    radius 0.3, which rounds the inner edge. A smooth union also bulges (by up to k/4) where
    both plates have a face in the same plane, so the union is trimmed by the bracket's sharp
    bounding box: the outer faces stay flat and their edges sharp. Returns
    ``(model, bolt_hole, base_plate)``.
    """
    base = sdf.box((4.0, 2.0, 0.6), center=(2.0, 1.0, 0.3))
    upright = sdf.box((0.6, 2.0, 3.0), center=(0.3, 1.0, 1.5))
    envelope = sdf.box((4.0, 2.0, 3.0), center=(2.0, 1.0, 1.5))
    hole = sdf.cylinder(radius=0.4, height=2.0, center=(2.8, 1.0, 0.3))
    return sdf.union(base, upright, k=0.3) & envelope - hole, hole, base


def l_bracket_corners() -> np.ndarray:
    """The 10 corners of :func:`l_bracket` (its inner edge is filleted: no corner there), (10, 3)."""
    return np.array([[0, 0, 0], [0, 2, 0], [0, 0, 3], [0.6, 0, 3], [0, 2, 3], [0.6, 2, 3],
                     [4, 0, 0], [4, 0, 0.6], [4, 2, 0], [4, 2, 0.6]], dtype=float)


#: Exact volume of :func:`slotted_box`: the 4 x 2 x 1 box less the 2.4 x 0.6 x 0.5 slot.
SLOTTED_BOX_VOLUME = 4.0 * 2.0 * 1.0 - 2.4 * 0.6 * 0.5


def slotted_box() -> tuple[Any, Any]:
    """A 4 x 2 x 1 box (z from 0 to 1) with a blind slot 2.4 long, 0.6 wide, 0.5 deep in its top.

    The slot has convex edges at its rim and concave edges at its floor. Returns
    ``(model, slot)``.
    """
    block = sdf.box((4.0, 2.0, 1.0), center=(0.0, 0.0, 0.5))
    slot = sdf.box((2.4, 0.6, 1.0), center=(0.0, 0.0, 1.0))
    return block - slot, slot


def slotted_box_corners() -> np.ndarray:
    """The 16 corners of :func:`slotted_box` (8 of the block, 8 of the slot), (16, 3)."""
    block = [[x, y, z] for x in (-2.0, 2.0) for y in (-1.0, 1.0) for z in (0.0, 1.0)]
    slot = [[x, y, z] for x in (-1.2, 1.2) for y in (-0.3, 0.3) for z in (0.5, 1.0)]
    return np.array(block + slot, dtype=float)


#: Volume of :func:`gyroid_block`: Monte Carlo with 2e7 points, 3.2775 +- 0.0003; flying edges
#: at spacing 0.005 encloses 3.2776.
GYROID_BLOCK_VOLUME = 3.2776


def gyroid_block() -> Any:
    """A 2 x 2 x 1 block: a shell of wall 0.2 filled with a gyroid sheet (period 1, thickness 0.15)."""
    block = sdf.box((2.0, 2.0, 1.0))
    return sdf.infill(block, sdf.gyroid(period=1.0, thickness=0.15), wall=0.2)


def occ_surface(build: Callable, size: float, curvature: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Surface triangles ``(vertices, faces)`` of an OpenCASCADE solid built by ``build(occ)``
    (``occ`` is ``gmsh.model.occ``), meshed by gmsh with elements of about ``size`` and
    ``curvature`` elements per 2 pi of a curved face (gmsh's ``Mesh.MeshSizeFromCurvature``)."""
    import gmsh

    from .distmesh.delaunay import initialize_gmsh

    initialize_gmsh()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("corpus")
        build(gmsh.model.occ)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", curvature)
        gmsh.model.mesh.generate(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, nodes = gmsh.model.mesh.getElementsByType(2)
    finally:
        gmsh.finalize()
    vertices = np.asarray(coords, float).reshape(-1, 3)
    index = np.zeros(int(np.max(tags)) + 1, dtype=np.int64)
    index[np.asarray(tags, np.int64)] = np.arange(len(tags))
    faces = index[np.asarray(nodes, np.int64).reshape(-1, 3)]
    # gmsh orients each surface by its own parametrisation: fepre's repair orients them
    return vertices, faces


def write_mounting_block_stl(path: Any, size: float = 2.0) -> Any:
    """Write a CAD part as a binary STL file, as a CAD system exports one, and return the path.

    The part is a 40 x 30 x 20 mounting block (millimetres) with two bolt holes through it
    (radius 4 at y = 10) and a slot across its top (y from 18 to 26, 6 deep), built in OpenCASCADE and tessellated by gmsh (triangles about ``size``
    long, finer on the holes).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = write_mounting_block_stl(pathlib.Path(tempfile.mkdtemp()) / "block.stl")
    >>> from fepre import sdf
    >>> block = sdf.mesh(path)
    >>> block.bounds
    ((0.0, 0.0, 0.0), (40.0, 30.0, 20.0))
    """
    from pathlib import Path

    import pyvista as pv

    def build(occ):
        block = occ.addBox(0, 0, 0, 40, 30, 20)
        holes = [(3, occ.addCylinder(x, 10, -1, 0, 0, 22, 4)) for x in (10, 30)]
        slot = occ.addBox(-1, 18, 14, 42, 8, 7)
        occ.cut([(3, block)], holes + [(3, slot)])

    vertices, faces = occ_surface(build, size)
    path = Path(path)
    pv.PolyData(vertices, np.column_stack([np.full(len(faces), 3), faces]).ravel()).save(str(path), binary=True)
    return path


def imported_infill(path: Any) -> Any:
    """The part in the STL file ``path`` with a gyroid core (period 16, sheet 3) under a solid
    skin 3 thick: the nTop-style use of an existing part, for printing and for analysis."""
    return sdf.infill(sdf.mesh(path), sdf.gyroid(period=16.0, thickness=3.0), wall=3.0)


def bone() -> Any:
    """A bone-like part: a shaft (capsule of radius 0.3 from x = -1.2 to 1.2) with a knuckle of
    radius 0.55 at each end, blended by a smooth union of radius 0.25 (smooth everywhere)."""
    shaft = sdf.capsule((-1.2, 0.0, 0.0), (1.2, 0.0, 0.0), radius=0.3)
    ends = [sdf.sphere(0.55, center=(x, 0.0, 0.0)) for x in (-1.3, 1.3)]
    return sdf.union(shaft, *ends, k=0.25)


def write_scan(model: Any, path: Any, voxel: float, *, noise: float = 50.0, seed: int = 0) -> Any:
    """A simulated CT scan of ``model`` to the ``.vti`` file ``path``: each voxel's partial volume
    times 1000 plus Gaussian noise of ``noise`` (seeded), over the model's box and 3 voxels more."""
    from .sdf.imagemodel.phantoms import partial_volume

    lower, upper = (np.asarray(v, dtype=np.float64) for v in model.bounds)
    grid = partial_volume(model, lower - 3 * voxel, upper + 3 * voxel, voxel, scale=1000.0)
    values = np.asarray(grid["density"], dtype=np.float64)
    grid["density"] = (values + np.random.default_rng(seed).normal(0.0, noise, values.shape)).astype(np.float32)
    grid.save(str(path))
    return path
