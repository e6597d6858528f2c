"""A triangle mesh as an SDF model."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ...arguments import finite_float
from ...errors import RepairWarning, warn_user
from ..core import SDF, Coords
from .distance import TriangleDistance
from .patches import PatchPlanes, segment_patches
from .read import MeshInputError, read_triangles
from .tables import enclosed_volume, used_vertices
from .openings import span_openings
from .repair import MAX_HOLE_FRACTION, Repair, repair
from .tables import face_normals

__all__ = ["MeshModel", "mesh"]

SIGNS = ("winding", "pseudonormal")
#: What the solid of a surface is: what it encloses once repaired, or where its winding number
#: exceeds 1/2 (open surfaces that no hole fill closes).
INSIDES = ("closed", "winding")


class MeshModel(SDF):
    """The solid enclosed by a triangle surface: exact distance to the triangles, signed.

    Built by :func:`fepre.sdf.mesh`; see there.
    """

    analytic_gradient = True

    def __init__(self, repaired: Repair, name: str, *, sign: str, features: float, inside: str = "closed") -> None:
        self.repaired = repaired
        self.name = name
        self.sign = sign
        self.inside = inside
        self.features = features
        vertices, faces = repaired.vertices, repaired.faces
        pseudonormal = repaired.closed and repaired.internal == 0
        self._distance = TriangleDistance(vertices, faces, pseudonormal=pseudonormal, tree=repaired.tree,
                                           face_sign=inside == "closed")
        normals = self._distance.normals
        if features > 0:
            self._face_patch, self._patch_count = segment_patches(faces, normals, features, self._distance.areas, repaired.filled)
        else:
            self._face_patch, self._patch_count = np.zeros(len(faces), np.int64), 1
        self._planes = PatchPlanes(vertices, faces, normals, self._face_patch)
        used = vertices[used_vertices(faces, len(vertices))]
        super().__init__(
            bounds=(tuple(used.min(axis=0)), tuple(used.max(axis=0))),
            # the distance is to the solid's boundary unless triangles were dropped from inside it
            exact=repaired.internal == 0,
        )

    # ------------------------------------------------------------------ description
    @property
    def vertices(self) -> np.ndarray:
        """Vertices (V, 3) of the repaired surface."""
        return self.repaired.vertices

    @property
    def faces(self) -> np.ndarray:
        """Triangles (F, 3) of the repaired surface, oriented outwards."""
        return self.repaired.faces

    @property
    def volume(self) -> float:
        """Volume enclosed by the repaired surface (taken about its centre: a surface whose
        spanned openings meet their rims without shared vertices is not quite closed, and about
        a far origin its gaps counted: 3.08 for a half ball of 2.05 moved to 1e4)."""
        return enclosed_volume(self.vertices, self.faces)

    def to_polydata(self):
        """The repaired surface as a ``pyvista.PolyData`` with a ``"patch"`` cell array."""
        import pyvista as pv

        faces = np.column_stack([np.full(len(self.faces), 3), self.faces]).ravel()
        surface = pv.PolyData(self.vertices, faces)
        surface.cell_data["patch"] = self._face_patch
        return surface.clean()

    def _parameters(self) -> dict[str, Any]:
        parameters: dict[str, Any] = {"source": self.name, "triangles": len(self.faces)}
        if self.sign != "winding":
            parameters["sign"] = self.sign
        if self.inside != "closed":
            parameters["inside"] = self.inside
        if self.features != 30.0:
            parameters["features"] = self.features
        return parameters

    def _label(self) -> str:
        return "mesh"

    # ------------------------------------------------------------------ the protocol
    def _evaluate_rows(self, array: np.ndarray, kernel, width: int = 0, workers: int | None = None):
        """Blocks of many points go to the threads in Z-order: each block is then a compact
        region, and the search of one point starts from its neighbour's triangle (1M points
        uniform in the box: 10% faster than blocks of scattered points)."""
        from ...config import config
        from .bvh import _z_order

        if array.shape[0] <= config.chunk_points or not np.isfinite(array).all():
            return super()._evaluate_rows(array, kernel, width, workers)
        order = _z_order(np.ascontiguousarray(array, dtype=np.float64))
        ordered = super()._evaluate_rows(array[order], kernel, width, workers)
        result = np.empty_like(ordered)
        result[order] = ordered
        return result

    @staticmethod
    def _stack(coords: tuple[np.ndarray, ...]) -> tuple[np.ndarray, tuple[int, ...], np.dtype]:
        arrays = np.broadcast_arrays(*coords)
        shape = arrays[0].shape
        points = np.empty((arrays[0].size, 3))
        for axis in range(3):
            points[:, axis] = arrays[axis].reshape(-1)
        dtype = np.result_type(*coords, np.float32)
        return points, shape, dtype

    def _values(self, x, y, z):
        points, shape, dtype = self._stack((np.asarray(x), np.asarray(y), np.asarray(z)))
        values = self._distance.values(points)[0]
        return values.reshape(shape).astype(dtype, copy=False)

    def _values_and_gradient(self, x, y, z) -> tuple[np.ndarray, Coords]:
        points, shape, dtype = self._stack((np.asarray(x), np.asarray(y), np.asarray(z)))
        values, _, _, direction = self._distance.signed(points)
        gradient = tuple(direction[:, k].reshape(shape) for k in range(3))
        return values.reshape(shape), gradient

    @property
    def creases_from_triangles(self) -> bool:
        """:func:`fepre.features` reads this model's creases from its triangles' edges between
        patches (:func:`fepre.features.mesh_creases.triangle_creases`) instead of searching a
        fine grid: when the repaired surface is closed, every edge shared by two triangles.
        The spans of ``inside="winding"`` meet their rims without shared edges (so do
        non-manifold seams), and the creases there are found on the grid."""
        return self.inside == "closed" and self.repaired.closed

    def triangle_patches(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Vertices (V, 3), triangles (F, 3), unit normals (F, 3) and each triangle's patch (F,)."""
        return self.vertices, self.faces, self._distance.normals, self._face_patch

    @property
    def patch_count(self) -> int:
        return self._patch_count

    def _patch_labels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        values, face = self._distance.values(np.asarray(points, dtype=np.float64))
        return values, self._face_patch[face]

    def _patch_values(self, labels: np.ndarray, points: np.ndarray) -> np.ndarray:
        return self._planes.values(labels, np.asarray(points, dtype=np.float64))

    def facet_curvature(self, points: Any, scale: float) -> np.ndarray:
        """The largest principal curvature of the surface at the facet nearest each point, as
        the facets show it at the length ``scale`` (:mod:`~fepre.sdf.meshmodel.facet_curvature`;
        the Hessian of a faceted surface is zero on every facet).

        Examples
        --------
        >>> import pyvista as pv
        >>> from fepre import sdf
        >>> ball = sdf.mesh(pv.Sphere(radius=2.0, theta_resolution=64, phi_resolution=64))
        >>> round(float(ball.facet_curvature([[0.0, 0.0, 2.0], [2.0, 0.0, 0.0]], scale=0.5).mean()), 2)
        0.49
        """
        from .facet_curvature import facet_curvatures

        key = float(scale)
        cache = self.__dict__.setdefault("_facet_curvature_cache", {})
        if key not in cache:
            cache[key] = facet_curvatures(self.repaired.vertices, self.repaired.faces, self._distance.normals,
                                          self._face_patch, self._distance.areas, key)
        _, face = self._distance.values(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        return cache[key][face]

    def project(self, points: Any, iterations: int = 10, tol: float | None = None, warn: bool = True) -> np.ndarray:
        """Closest points on the surface (exact: one step).

        Examples
        --------
        >>> import pyvista as pv
        >>> from fepre import sdf
        >>> cube = sdf.mesh(pv.Cube())
        >>> cube.project([[2.0, 0.1, 0.2]]).round(12).tolist()
        [[0.5, 0.1, 0.2]]
        """
        from ...arguments import as_points

        array, single = as_points(points, 3)
        _, _, closest = self._distance.closest(array)
        return closest[0] if single else closest


def mesh(source: Any, *, sign: str = "winding", features: float = 30.0, inside: str = "closed") -> MeshModel:
    """The solid enclosed by a triangle mesh, as a model.

    Values are the exact Euclidean distance to the triangles (fepre's own bounding-volume
    hierarchy, compiled, not a grid), negative inside; the sign comes from pseudonormals on a
    closed surface, else from the generalised winding number (libigl's fast one). The input is repaired first (see
    :mod:`fepre.sdf.meshmodel.repair`): vertices merged, duplicate and degenerate triangles
    dropped, orientation made consistent, holes closed with fans, triangles that do not
    separate inside from outside (inner parts of overlapping shells) dropped. The model is
    ``exact`` unless triangles had to be dropped from inside the solid; then the values near
    those overlaps are distances to the remaining triangles, a lower bound there.

    Parameters
    ----------
    source : str, path-like or pyvista.PolyData
        A surface file (STL, OBJ, PLY, VTK/VTP, anything PyVista or meshio reads) or a surface.
        Polygons are triangulated.
    sign : {"winding", "pseudonormal"}
        How inside is decided. ``"winding"`` (default): the generalised winding number exceeds
        1/2, right on dirty input; on a surface that repairs to a closed, consistently oriented
        manifold the pseudonormal test gives the same answer faster and is used. ``"pseudonormal"``
        insists on that test and is an error when the surface does not repair to a closed one.
    features : float
        Edges whose two triangles' normals differ by more than this many degrees are sharp:
        :func:`fepre.features` and DistMesh keep them as feature curves and corners. 0 treats
        the whole surface as smooth.
    inside : {"closed", "winding"}
        What the solid is. ``"closed"`` (default): what the repaired surface encloses; an open
        surface whose holes would add more than ``MAX_HOLE_FRACTION`` of its area is refused.
        ``"winding"``: where the generalised winding number of the triangles exceeds 1/2
        (Jacobson et al. 2013), for scans with large openings and overlapping open sheets: no
        hole is filled; the model is the distance to the input triangles that bound that set
        plus surfaces spanning its openings (the ``w = 1/2`` level set, see
        :mod:`fepre.sdf.meshmodel.openings`), signed by the winding number.

    Returns
    -------
    MeshModel
        An :class:`~fepre.sdf.SDF` with ``vertices``, ``faces``, ``volume``, ``repaired``
        (what was fixed) and ``to_polydata()``.

    Raises
    ------
    fepre.sdf.meshmodel.MeshInputError
        The file is missing or unreadable, holds no triangles, has NaN coordinates, or the
        surface has no inside (an open sheet, a bowl).

    Examples
    --------
    >>> import pyvista as pv
    >>> from fepre import sdf
    >>> ball = sdf.mesh(pv.Sphere(radius=1.0, theta_resolution=64, phi_resolution=64))
    >>> round(float(ball([0.0, 0.0, 0.0])), 3), ball.exact
    (-0.998, True)
    >>> part = ball - sdf.cylinder(radius=0.3, height=3.0)   # combines with CSG
    >>> float(part([0.0, 0.0, 0.0]))
    0.3
    >>> bowl = pv.Sphere(theta_resolution=48, phi_resolution=48).clip(normal="-z", origin=(0, 0, 0))
    >>> cap = sdf.mesh(bowl, inside="winding")                 # an open hemisphere: its solid
    >>> round(float(cap([0.0, 0.0, 0.2])), 3), round(cap.volume / (3.14159 / 12), 2)
    (-0.2, 1.0)
    """
    if inside not in INSIDES:
        raise ValueError(f"inside must be one of {', '.join(map(repr, INSIDES))}; got {inside!r}")
    if sign not in SIGNS:
        raise ValueError(f"sign must be one of {', '.join(map(repr, SIGNS))}; got {sign!r}")
    features = finite_float(features, "features")
    if not 0.0 <= features < 180.0:
        raise ValueError(f"features must be an angle in degrees in [0, 180); got {features!r}")
    vertices, faces, name = read_triangles(source)
    _check_not_flat(vertices, faces, name)
    if inside == "winding":
        if sign == "pseudonormal":
            raise MeshInputError(f"{name}: inside='winding' signs by the winding number; use sign='winding'")
        repaired = span_openings(vertices, faces)
        _check_volume(repaired, name, winding=True)
    else:
        repaired = repair(vertices, faces)
        _check_solid(repaired, name)
        _warn_of_changes(repaired, vertices[used_vertices(faces, len(vertices))], name)
    if sign == "pseudonormal" and not (repaired.closed and repaired.internal == 0):
        raise MeshInputError(
            f"{name}: sign='pseudonormal' needs a closed, consistently oriented surface, and this one is not "
            f"after repair ({repaired.summary() or 'non-manifold edges'}); use sign='winding'"
        )
    if isinstance(source, (str, os.PathLike)):
        name = os.fspath(source)
    return MeshModel(repaired, name, sign=sign, features=features, inside=inside)


#: A repair that changes the volume by more than this fraction (beyond flat caps on holes) warns.
REPAIR_VOLUME_WARNING = 0.005
#: ... or whose patches reach past the input's bounds by more than this share of its largest
#: extent (a faired patch on stanford-bunny's base reached 2.3e-5 below it, 0.015%, and warned)
REPAIR_BOUNDS_WARNING = 1e-3


def _box(lower: np.ndarray, upper: np.ndarray) -> str:
    return f"({', '.join(f'{v:.6g}' for v in lower)}) to ({', '.join(f'{v:.6g}' for v in upper)})"


def _warn_of_changes(repaired: Repair, given: np.ndarray, name: str) -> None:
    """Warn when the hole patches change the solid by more than REPAIR_VOLUME_WARNING of its
    volume beyond flat caps, or reach past the input's bounds by more than
    REPAIR_BOUNDS_WARNING of its largest extent."""
    volume = abs(enclosed_volume(repaired.vertices, repaired.faces))
    used = repaired.vertices[used_vertices(repaired.faces, len(repaired.vertices))]
    lower, upper = given.min(axis=0), given.max(axis=0)
    reach = float(np.maximum(lower - used.min(axis=0), used.max(axis=0) - upper).max())
    changes = []
    if abs(repaired.hole_bulge) > REPAIR_VOLUME_WARNING * volume:
        changes.append(
            f"the smooth patches on its {repaired.holes - repaired.flat_holes} non-planar hole(s) "
            f"{'add' if repaired.hole_bulge > 0 else 'remove'} a volume of {abs(repaired.hole_bulge):.4g} "
            f"({100 * abs(repaired.hole_bulge) / volume:.2f}% of {volume:.4g}) beyond flat caps")
    if reach > REPAIR_BOUNDS_WARNING * float(np.ptp(given, axis=0).max()):
        changes.append(
            f"the patches reach {reach:.4g} past the input's bounds ({_box(lower, upper)} -> "
            f"{_box(used.min(axis=0), used.max(axis=0))})")
    if changes:
        warn_user(f"{name}: closing holes changed the solid: {'; '.join(changes)}; close the holes in the "
                  "source if this is not the part", RepairWarning)


def _check_not_flat(vertices: np.ndarray, faces: np.ndarray, name: str) -> None:
    """A surface whose vertices all lie in one plane (a 2D mesh) has no inside."""
    used = vertices[used_vertices(faces, len(vertices))] if len(faces) else vertices
    if len(used) < 3:
        return
    centred = used - used.mean(axis=0)
    spread = np.linalg.svd(centred[:: max(1, len(centred) // 100_000)], compute_uv=False)
    if spread[-1] <= 1e-9 * spread[0]:
        lower, upper = used.min(axis=0), used.max(axis=0)
        raise MeshInputError(
            f"{name} has no inside: it is flat, all its {len(used)} vertices in one plane (bounds "
            f"{_box(lower, upper)}); give the closed surface of a solid (a 2D mesh is not one)")


def _check_solid(repaired: Repair, name: str) -> None:
    """The repaired surface must enclose a solid.

    The holes' patches are measured against the input's own triangles that bound the solid (not
    those dropped as inner walls). The repaired surface's area less all the patches, some of them
    dropped too, was negative on truck.obj ("would add -892% of its area"): its patches add 150%
    of the 15% of its area left once its holes are closed.
    """
    if len(repaired.faces) == 0:
        raise MeshInputError(
            f"{name} has no inside: none of its triangles separates an inside from an outside (loose triangles "
            "or sheets that close nothing); give the closed surface of a solid, or pass inside='winding' (CLI: "
            "--inside winding) if its triangles wrap a solid with gaps between them")
    _, areas = face_normals(repaired.vertices, repaired.faces)
    given = float(areas[~repaired.filled].sum())  # the input's own area, without the patches
    if repaired.holes and repaired.hole_area > MAX_HOLE_FRACTION * given:
        raise MeshInputError(
            f"{name} has no inside: it is an open surface, and closing its {repaired.holes} boundary loop(s) "
            f"would add {100 * repaired.hole_area / given:.0f}% of its area (fepre closes holes up to "
            f"{100 * MAX_HOLE_FRACTION:.0f}% of it); give a closed surface, or pass inside='winding' (CLI: --inside "
            "winding) to mesh the solid where its generalised winding number exceeds 1/2"
        )
    _check_volume(repaired, name)


def _check_volume(repaired: Repair, name: str, winding: bool = False) -> None:
    """The surface must enclose a positive volume (``winding``: once spanned across its openings)."""
    if len(repaired.faces) == 0:
        raise MeshInputError(f"{name} has no inside: none of its triangles separates an inside from an outside")
    volume = enclosed_volume(repaired.vertices, repaired.faces)
    extent = np.ptp(repaired.vertices[used_vertices(repaired.faces, len(repaired.vertices))], axis=0)
    if volume <= 1e-9 * float(np.prod(np.maximum(extent, 1e-300))) or not np.isfinite(volume):
        if winding:
            raise MeshInputError(
                f"{name} has no inside with inside='winding': its generalised winding number exceeds 1/2 "
                f"nowhere (spanned across its openings it encloses a volume of {volume:.3g}): an open sheet "
                "bounds no solid; give the closed surface of a solid, or a surface that wraps one")
        raise MeshInputError(f"{name} has no inside: the surface encloses a volume of {volume:.3g}")
