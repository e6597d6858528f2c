"""A corpus of triangle-mesh inputs: clean surfaces of many kinds and dirty variants of them.

Clean inputs are what users bring: CAD parts tessellated by OpenCASCADE (through gmsh), closed
fepre surfaces of CSG parts, lattices and smooth sculpted blobs. Dirty variants carry the defects
of real files, each made on purpose so that the truth is known: holes (up to 2% of the area),
duplicated triangles, flipped triangles, overlapping shells, edges shared by four triangles, and a
surface of a million triangles. ``fepre bench mesh-models`` meshes every input with fepre and
pytetwild.

Examples
--------
>>> from fepre.corpus.meshes import mesh_inputs
>>> inputs = mesh_inputs(names=["occ-box-hole", "occ-box-hole+flipped"])
>>> [(i.name, i.dirt) for i in inputs]
[('occ-box-hole', 'clean'), ('occ-box-hole+flipped', 'flipped')]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable, Optional

import numpy as np

from ..parts import occ_surface as _occ  # the corpus's CAD parts, tessellated by gmsh

__all__ = ["MeshInput", "mesh_inputs", "winding_volume", "feature_edges", "CLEAN", "DIRT"]

DIRT = ("holes", "duplicates", "flipped", "overlap", "non-manifold", "million")


@dataclass(frozen=True)
class MeshInput:
    """One input surface of the corpus.

    Attributes
    ----------
    name : str
    kind : str
        "cad", "csg", "lattice" or "blob".
    dirt : str
        "clean" or one of ``DIRT``.
    vertices, faces : ndarray
        The triangles, as a file would hold them.
    h : float
        Edge length to mesh it at.
    sharp : bool
        The part has sharp edges that a mesh should keep.
    """

    name: str
    kind: str
    dirt: str
    vertices: np.ndarray
    faces: np.ndarray
    h: float
    sharp: bool

    def to_polydata(self):
        """The triangles as a ``pyvista.PolyData`` (vertices as given, not merged)."""
        import pyvista as pv

        return pv.PolyData(self.vertices, np.column_stack([np.full(len(self.faces), 3), self.faces]).ravel())

    def __repr__(self) -> str:
        return f"MeshInput({self.name!r}, {len(self.faces)} triangles, h={self.h:g})"


# ---------------------------------------------------------------------------- clean sources
def _box_hole(o):
    box = o.addBox(0, 0, 0, 50, 50, 50)
    o.cut([(3, box)], [(3, o.addCylinder(25, 25, -1, 0, 0, 52, 10))])


def _flange(o):
    disk = o.addCylinder(0, 0, 0, 0, 0, 10, 50)
    hub = o.addCylinder(0, 0, 0, 0, 0, 30, 20)
    body = o.fuse([(3, disk)], [(3, hub)])[0]
    cuts = [(3, o.addCylinder(0, 0, -1, 0, 0, 32, 10))]
    for k in range(6):
        angle = 2 * math.pi * k / 6
        cuts.append((3, o.addCylinder(35 * math.cos(angle), 35 * math.sin(angle), -1, 0, 0, 12, 4)))
    o.cut(body, cuts)


def _bracket(o):
    base = o.addBox(0, 0, 0, 80, 40, 10)
    wall = o.addBox(0, 0, 0, 10, 40, 60)
    body = o.fuse([(3, base)], [(3, wall)])[0]
    holes = [(3, o.addCylinder(x, 20, -1, 0, 0, 12, 5)) for x in (35, 60)]
    holes.append((3, o.addCylinder(-1, 20, 40, 12, 0, 0, 6)))
    o.cut(body, holes)


def _slotted_block(o):
    block = o.addBox(0, 0, 0, 60, 30, 20)
    slot = o.addBox(10, 10, 8, 40, 10, 13)
    pocket = o.addCylinder(15, 15, 5, 0, 0, 20, 3)
    o.cut([(3, block)], [(3, slot), (3, pocket)])


def _shaft(o):
    parts = [o.addCylinder(0, 0, z, 0, 0, length, r) for z, length, r in ((0, 30, 10), (30, 40, 15), (70, 20, 8))]
    o.fuse([(3, parts[0])], [(3, p) for p in parts[1:]])


def _tube(o):
    outer = o.addCylinder(0, 0, 0, 0, 0, 60, 20)
    inner = o.addCylinder(0, 0, -1, 0, 0, 62, 16)
    o.cut([(3, outer)], [(3, inner)])


def _cone_on_box(o):
    box = o.addBox(-30, -30, 0, 60, 60, 15)
    cone = o.addCone(0, 0, 15, 0, 0, 30, 25, 5)
    body = o.fuse([(3, box)], [(3, cone)])[0]
    o.cut(body, [(3, o.addSphere(0, 0, 50, 8))])


def _rounded_plate(o):
    """A plate with rounded corners (quarter cylinders) and four holes."""
    plate = o.addBox(0, 0, 0, 80, 50, 8)
    corners = []
    for x, y, sx, sy in ((0, 0, 1, 1), (80, 0, -1, 1), (0, 50, 1, -1), (80, 50, -1, -1)):
        square = o.addBox(x - (sx < 0) * 6, y - (sy < 0) * 6, -1, 6, 6, 10)
        round_ = o.addCylinder(x + sx * 6, y + sy * 6, -1, 0, 0, 10, 6)
        corners.extend(o.cut([(3, square)], [(3, round_)])[0])
    holes = [(3, o.addCylinder(x, y, -1, 0, 0, 10, 4)) for x in (15, 65) for y in (12, 38)]
    o.cut([(3, plate)], corners + holes)


_CAD = {
    "occ-box-hole": (_box_hole, 3.0, 5.0),
    "occ-flange": (_flange, 3.0, 3.0),
    "occ-bracket": (_bracket, 3.0, 4.0),
    "occ-slotted-block": (_slotted_block, 2.0, 2.5),
    "occ-shaft": (_shaft, 3.0, 2.5),
    "occ-tube": (_tube, 2.0, 2.0),
    "occ-cone-on-box": (_cone_on_box, 2.5, 3.5),
    "occ-rounded-plate": (_rounded_plate, 2.0, 2.5),
}


def _surface(model, spacing: float, method: str) -> tuple[np.ndarray, np.ndarray]:
    from ..surface import isosurface

    surface = isosurface(model, method=method, spacing=spacing)
    return np.asarray(surface.points, float), surface.faces.reshape(-1, 4)[:, 1:].astype(np.int64)


def _csg_parts() -> dict[str, tuple[Callable, float, bool, str]]:
    from .. import parts, sdf

    def cube_hole():
        return parts.cube_with_hole()[0]

    def bracket():
        return parts.l_bracket()[0]

    def slotted():
        return parts.slotted_box()[0]

    def gyroid():
        return parts.gyroid_block()

    def schwarz():
        # the skin's inner faces (x = +-1) are mirror planes of the lattice: it meets them square
        box = sdf.box(2.2)
        return sdf.infill(box, sdf.schwarz_p(period=1.0, thickness=0.12), wall=0.1)

    def blob(seed: int):
        def build():
            rng = np.random.default_rng(seed)
            shape = sdf.sphere(1.0)
            for _ in range(6):
                centre = rng.normal(0, 0.7, 3)
                shape = sdf.union(shape, sdf.sphere(float(rng.uniform(0.3, 0.7)), center=centre), k=0.3)
            return shape

        return build

    def torus():
        return sdf.torus(2.0, 0.6)

    # name: (model, spacing, sharp, method), spacing in the part's units
    return {
        "csg-cube-hole": (cube_hole, 0.1, True, "dual_contouring"),
        "csg-l-bracket": (bracket, 0.06, True, "dual_contouring"),
        "csg-slotted-box": (slotted, 0.05, True, "dual_contouring"),
        "lattice-gyroid-block": (gyroid, 0.02, False, "flying_edges"),
        "lattice-schwarz-cube": (schwarz, 0.025, False, "flying_edges"),
        "blob-1": (blob(1), 0.04, False, "flying_edges"),
        "blob-2": (blob(2), 0.04, False, "flying_edges"),
        "blob-torus": (torus, 0.05, False, "flying_edges"),
    }


_CSG_H = {
    "csg-cube-hole": 0.35,
    "csg-l-bracket": 0.2,
    "csg-slotted-box": 0.15,
    "lattice-gyroid-block": 0.05,
    "lattice-schwarz-cube": 0.06,
    "blob-1": 0.12,
    "blob-2": 0.12,
    "blob-torus": 0.14,
}


def _clean_sources() -> dict[str, Callable[[], MeshInput]]:
    sources: dict[str, Callable[[], MeshInput]] = {}
    for name, (build, size, h) in _CAD.items():
        sources[name] = lambda name=name, build=build, size=size, h=h: MeshInput(
            name, "cad", "clean", *_occ(build, size), h=h, sharp=True
        )
    for name, (model, spacing, sharp, method) in _csg_parts().items():
        kind = name.split("-")[0]
        sources[name] = lambda name=name, model=model, spacing=spacing, sharp=sharp, method=method, kind=kind: MeshInput(
            name, kind, "clean", *_surface(model(), spacing, method), h=_CSG_H[name], sharp=sharp
        )
    return sources


CLEAN = tuple(_CAD) + tuple(_CSG_H)

# ---------------------------------------------------------------------------- dirty variants
#: The inputs each defect is applied to.
_DIRTY = {
    "holes": ("occ-box-hole", "occ-flange", "blob-1", "csg-l-bracket"),
    "duplicates": ("occ-bracket", "blob-2"),
    "flipped": ("occ-box-hole", "occ-shaft", "lattice-gyroid-block"),
    "overlap": ("occ-slotted-block",),
    "non-manifold": ("occ-tube",),
    "million": ("occ-flange",),
}


def _punch_holes(base: MeshInput, rng, fraction: float = 0.02, holes: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Remove triangles around ``holes`` random centres until ``fraction`` of the area is gone."""
    from ..sdf.meshmodel.tables import face_normals

    _, area = face_normals(base.vertices, base.faces)
    centroid = base.vertices[base.faces].mean(axis=1)
    keep = np.ones(len(base.faces), bool)
    target = fraction * area.sum() / holes
    for centre in rng.choice(len(base.faces), holes, replace=False):
        order = np.argsort(np.linalg.norm(centroid - centroid[centre], axis=1))
        taken = order[: max(1, int(np.searchsorted(np.cumsum(area[order]), target)))]
        keep[taken] = False
    return base.vertices, base.faces[keep]


def _overlap(base: MeshInput) -> tuple[np.ndarray, np.ndarray]:
    """The part plus a bar through its lower part, sticking out on both sides, written as two
    overlapping shells."""
    import pyvista as pv

    lower, upper = base.vertices.min(axis=0), base.vertices.max(axis=0)
    centre = (lower + upper) / 2
    extent = upper - lower
    box = pv.Box(bounds=(centre[0] - 0.15 * extent[0], centre[0] + 0.15 * extent[0],
                         centre[1] - 0.8 * extent[1], centre[1] + 0.8 * extent[1],
                         lower[2] - 0.1 * extent[2], lower[2] + 0.3 * extent[2]), level=6).triangulate()
    faces = box.faces.reshape(-1, 4)[:, 1:] + len(base.vertices)
    return np.concatenate([base.vertices, np.asarray(box.points, float)]), np.concatenate([base.faces, faces])


def _non_manifold(base: MeshInput) -> tuple[np.ndarray, np.ndarray]:
    """The part plus a copy moved diagonally so that they share one edge of their boxes."""
    lower, upper = base.vertices.min(axis=0), base.vertices.max(axis=0)
    shift = np.array([upper[0] - lower[0], upper[1] - lower[1], 0.0])
    return np.concatenate([base.vertices, base.vertices + shift]), np.concatenate([base.faces, base.faces + len(base.vertices)])


def _million(name: str) -> tuple[np.ndarray, np.ndarray]:
    build, _, _ = _CAD[name]
    return _occ(build, 0.25)


def _soup(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle with its own three vertices, as an STL file stores them."""
    return vertices[faces].reshape(-1, 3), np.arange(3 * len(faces)).reshape(-1, 3)


def _dirty(base: MeshInput, dirt: str, rng) -> MeshInput:
    if dirt == "holes":
        vertices, faces = _punch_holes(base, rng)
    elif dirt == "duplicates":
        extra = rng.choice(len(base.faces), len(base.faces) // 10, replace=False)
        vertices, faces = _soup(base.vertices, np.concatenate([base.faces, base.faces[extra]]))
    elif dirt == "flipped":
        faces = base.faces.copy()
        turn = rng.random(len(faces)) < 0.1
        faces[turn] = faces[turn, ::-1]
        vertices = base.vertices
    elif dirt == "overlap":
        vertices, faces = _overlap(base)
    elif dirt == "non-manifold":
        vertices, faces = _non_manifold(base)
    elif dirt == "million":
        vertices, faces = _million(base.name)
    else:  # pragma: no cover - the names come from DIRT
        raise ValueError(dirt)
    return MeshInput(f"{base.name}+{dirt}", base.kind, dirt, vertices, faces, base.h, base.sharp)


def mesh_inputs(seed: int = 0, names: Optional[Iterable[str]] = None) -> list[MeshInput]:
    """The corpus: every clean input, then the dirty variants (``base+dirt``).

    Parameters
    ----------
    seed : int
        Seed of the random defects.
    names : iterable of str, optional
        Only these inputs (clean names or ``base+dirt``).
    """
    sources = _clean_sources()
    wanted = None if names is None else list(names)
    every = list(sources) + [f"{base}+{dirt}" for dirt, bases in _DIRTY.items() for base in bases]
    if wanted is not None:
        unknown = [n for n in wanted if n not in every]
        if unknown:
            raise ValueError(f"unknown mesh inputs {unknown}; available: {', '.join(every)}")
    rng = np.random.default_rng(seed)
    built: dict[str, MeshInput] = {}

    def base(name: str) -> MeshInput:
        if name not in built:
            built[name] = sources[name]()
        return built[name]

    result = []
    for name in every:
        if wanted is not None and name not in wanted:
            if "+" in name:  # keep the random stream the same whichever inputs are asked for
                rng.random()
            continue
        if "+" in name:
            source, dirt = name.split("+")
            result.append(_dirty(base(source), dirt, np.random.default_rng([seed, every.index(name)])))
        else:
            result.append(base(name))
    return result


def winding_volume(vertices: np.ndarray, faces: np.ndarray, samples: int = 400_000, seed: int = 0) -> tuple[float, float]:
    """Volume where the input's generalised winding number exceeds 1/2, and its standard error
    (uniform samples in the bounding box, libigl's winding numbers of the triangles as given)."""
    from ..sdf.meshmodel.tables import winding_numbers

    lower, upper = vertices[np.unique(faces)].min(axis=0), vertices[np.unique(faces)].max(axis=0)
    rng = np.random.default_rng(seed)
    points = rng.uniform(lower, upper, (samples, 3))
    inside = float(np.mean(winding_numbers(vertices, faces, points) > 0.5))
    box = float(np.prod(upper - lower))
    return inside * box, box * math.sqrt(max(inside * (1 - inside), 1e-12) / samples)


def feature_edges(vertices: np.ndarray, faces: np.ndarray, angle: float = 30.0, step: float = 1.0) -> np.ndarray:
    """Points about ``step`` apart along the edges where the surface bends by more than ``angle``
    degrees (the repaired surface's sharp edges), (N, 3)."""
    from ..sdf.meshmodel.tables import edge_table, face_normals

    normals, _ = face_normals(vertices, faces)
    edges, face_edge, _ = edge_table(faces)
    owners = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(face_edge.reshape(-1), kind="stable")
    edge = face_edge.reshape(-1)[order]
    counts = np.bincount(edge, minlength=len(edges))
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    two = np.flatnonzero(counts == 2)
    a, b = owners[order][starts[two]], owners[order][starts[two] + 1]
    sharp = np.einsum("ij,ij->i", normals[a], normals[b]) < math.cos(math.radians(angle))
    ends = vertices[edges[two[sharp]]]
    if len(ends) == 0:
        return np.zeros((0, 3))
    length = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    pieces = np.maximum(1, np.ceil(length / step)).astype(np.int64)
    which = np.repeat(np.arange(len(ends)), pieces + 1)
    first = np.concatenate([[0], np.cumsum(pieces + 1)[:-1]])
    t = (np.arange(len(which)) - first[which]) / pieces[which]
    return ends[which, 0] + t[:, None] * (ends[which, 1] - ends[which, 0])
